"""``deformsim adapt``: a trained model adapted to a folder of the user's unlabelled photos
(:mod:`deformsim.learn.adapter`); ``predict --adapt`` does the same in memory on the photos it judges.

Whatever subfolders the photos sit in, no label is read: the folder is listed recursively and its photos ordered
by content, copies counted once. The adapted model records the sha256 of each photo it adapted on
(``adapted_unlabelled``): scoring it on them is *transductive*, and evaluate and the benchmarks say so.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from deformsim.errors import UserError
from deformsim.identity import digest, file_digest
from deformsim.learn.adapt_file import AdaptFile
from deformsim.learn.adapter import FEW_PHOTOS, MIN_PHOTOS, NETWORKS, Adapter, AdaptRecipe, em_prior, fit_adapter
from deformsim.learn.stack import Choice, fit_stack
from deformsim.log import get_logger
from deformsim.records import made

log = get_logger(__name__)


@dataclass
class Adapted:
    """An adapted model in its folder, the photos it adapted on (``labelled`` of them with their labels), their
    estimated share of deformed parts, the share judged deformed before and after adapting, and what a stacked
    model's cross-validation chose (:class:`deformsim.learn.stack.Choice`, ``None`` for the other methods)."""

    model_path: Path
    photos: int
    prior: float
    deformed_before: float
    deformed_after: float
    seconds: float
    labelled: int = 0
    choice: Choice | None = None


def unlabelled_photos(folder: Path, flag: str = "--photos") -> tuple[list[str], list[str]]:
    """The photos under ``folder`` (recursively; labels never read), one per content, ordered by their sha256, and
    those digests; one line when the folder is missing, a generated dataset, or holds fewer than
    :data:`MIN_PHOTOS` distinct photos."""
    from deformsim.dataset.real import expand_images

    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"{flag} folder not found: {folder}")
    for parent in [folder.resolve(), *folder.resolve().parents]:
        if (parent / "manifest.parquet").is_file():
            raise UserError(f"{flag} {folder} lies in the generated dataset {parent}: adapt on photos of real parts, "
                            "not on renders")
    return distinct_photos(expand_images([folder]), f"{flag} {folder}")


def distinct_photos(paths: list, where: str) -> tuple[list[str], list[str]]:
    """``paths`` one per content, ordered by their sha256, and those digests; one line naming ``where`` when fewer
    than :data:`MIN_PHOTOS` are distinct."""
    by_digest: dict[str, str] = {}
    for path in paths:
        by_digest.setdefault(file_digest(path), str(path))
    if len(by_digest) < MIN_PHOTOS:
        raise UserError(f"{where} holds {len(by_digest)} distinct photo(s): adapting needs at least {MIN_PHOTOS}")
    digests = sorted(by_digest)
    return [by_digest[d] for d in digests], digests


def check_adaptable(predictor) -> None:
    """One line unless ``predictor``'s model is a label classifier not adapted yet."""
    if predictor.target != "label":
        raise UserError(f"{predictor.path} predicts train.target {predictor.target}: adapting needs a label classifier")
    if predictor.adapter is not None:
        raise UserError(f"{predictor.path} is adapted already: adapt the model it was made from")


def labelled_photos(folder: Path) -> tuple[list[str], np.ndarray, list[str]]:
    """The photos of a labelled folder (``intact/`` + ``deformed/``), one per content ordered by sha256, their
    labels (1 deformed) and digests; one line when the folder is missing or a copy sits in both classes."""
    from deformsim.dataset.real import real_table

    table = real_table(folder)
    table["digest"] = [file_digest(p) for p in table["path"]]
    both = table.groupby("digest")["y"].nunique()
    if (both > 1).any():
        raise UserError(f"--labelled {folder}: copies of one photo are labelled both intact and deformed, e.g. "
                        f"{table.loc[table['digest'] == both.idxmax(), 'path'].iloc[0]}")
    table = table.drop_duplicates("digest").sort_values("digest")
    return list(table["path"]), table["y"].to_numpy(), list(table["digest"])


def not_labelled(paths: list[str], digests: list[str], labelled: list[str]) -> tuple[list[str], list[str]]:
    """The unlabelled ``paths`` and their ``digests`` less the copies of a ``labelled`` photo (digests): a photo given
    with its label counts as labelled."""
    seen = set(labelled)
    kept = [i for i, d in enumerate(digests) if d not in seen]
    return [paths[i] for i in kept], [digests[i] for i in kept]


def with_adapter(ckpt: dict, adapter: Adapter, unlabelled: list[str], labelled: list[str] = ()) -> dict:
    """The saved model ``ckpt`` with ``adapter`` and the digests of the photos it adapted on, the ``unlabelled`` ones
    added to ``adapted_unlabelled`` and the ``labelled`` ones (if any) to ``adapted_on``."""
    adapted = dict(ckpt, adapter=adapter.to_dict(),
                   adapted_unlabelled=sorted(set(ckpt.get("adapted_unlabelled", [])) | set(unlabelled)))
    if labelled:
        adapted["adapted_on"] = sorted(set(ckpt.get("adapted_on", [])) | set(labelled))
    return adapted


def fit_on(predictor, paths: list[str], recipe: AdaptRecipe, labels: np.ndarray | None = None,
           groups: list[str] | None = None) -> tuple[Adapter, np.ndarray, np.ndarray, Choice | None]:
    """The adapter of ``predictor`` (:class:`deformsim.learn.predict.Predictor`, not adapted yet) fitted on
    ``paths`` (``labels`` 0/1, -1 unlabelled, in shooting sessions ``groups``), the photos' probabilities before
    and after adapting, and what a stacked adapter's cross-validation chose."""
    check_adaptable(predictor)
    if recipe.method in NETWORKS:
        raise UserError(f"adapt method {recipe.method} retrains the networks on the renders and the photos: "
                        "use deformsim adapt with --data")
    if recipe.method == "stack" and labels is None:
        raise UserError("adapt method stack fits labelled photos: give them with --labelled")
    p, features = predictor.outputs_and_features(paths, recipe.probe)
    choice = None
    if recipe.method == "stack":
        adapter, choice = fit_stack(p, features, labels, groups)
    else:
        adapter = fit_adapter(p, features, recipe, labels)
    return adapter, p, adapter.apply(p, features), choice


def adapt_model(model: Path, photos: Path | None, out: Path, recipe: AdaptRecipe = AdaptRecipe(),
                overwrite: bool = False, progress: bool = True, labelled: Path | None = None,
                groups: str = "date", data: Path | None = None, variant: str | None = None) -> Adapted:
    """Adapt ``model`` to the unlabelled ``photos`` and the ``labelled`` ones (either may be ``None``; shooting
    sessions by ``groups``, :mod:`deformsim.dataset.groups`) and save it into ``out`` (``model.pt``, ``adapt.json``).
    The methods that train the networks (``fixmatch``, ``adamatch``, ``mcc``: :mod:`deformsim.learn.fixmatch`) take
    unlabelled photos alone and mix in the renders of ``data`` (its ``variant``, default the one the model was
    trained on).

    Refused with one line before any work: see :func:`unlabelled_photos` and :func:`labelled_photos`; a model that
    is not a label classifier or is adapted already; ``out`` refused as ``deformsim train`` refuses it, or holding
    the model or the photos; a method that trains the networks without ``data`` or ``photos``, or with ``labelled``.
    """
    from deformsim.dataset.groups import photo_groups
    from deformsim.learn import checkpoint
    from deformsim.learn.predict import Predictor
    from deformsim.learn.stage import images_digest, model_renders
    from deformsim.outputs import check_apart, check_folder_target, check_outside, claim, replacing

    start = time.perf_counter()
    if photos is None and labelled is None:
        raise UserError("adapt needs photos: --photos (unlabelled), --labelled, or both")
    networks = recipe.method in NETWORKS
    if networks and (photos is None or labelled is not None or data is None):
        wrong = "takes no --labelled" if labelled is not None else f"needs {'--photos' if photos is None else '--data'}"
        raise UserError(f"adapt method {recipe.method} {wrong}: it learns from unlabelled photos (--photos) beside the "
                        "renders the model was trained on (--data), without --labelled")
    if not networks and (data is not None or variant is not None):
        raise UserError(f"--data and --variant go with the methods {', '.join(NETWORKS)}, not {recipe.method}")
    out = check_folder_target(out, "--out")
    ckpt, path = checkpoint.read_checkpoint(model)
    renders = model_renders(data, variant, path, checkpoint.saved_config(ckpt, path)) if networks else None
    known, y, known_digests = labelled_photos(labelled) if labelled is not None else ([], np.zeros(0, int), [])
    paths, digests = unlabelled_photos(photos) if photos is not None else ([], [])
    paths, digests = not_labelled(paths, digests, known_digests)
    sources = {"photos": photos, "labelled": labelled, "data": data}
    check_apart(out, "--out", {"model": path, **{k: v for k, v in sources.items() if v is not None}})
    check_outside(out, "--out", {k: v for k, v in sources.items() if v is not None})
    sessions = photo_groups(known, groups)
    predictor = Predictor(ckpt, path, progress)
    check_adaptable(predictor)
    identity = {"settings": {"adapt": asdict(recipe), "groups": digest(sessions)},
                "inputs": {"model": file_digest(path), "photos": digest(digests),
                           "labelled": digest([f"{d} {int(v)}" for d, v in zip(known_digests, y)]),
                           **({"renders": images_digest(renders, data)} if networks else {})}}
    claim(out, "model", identity, overwrite)
    if networks:
        adapted, before, after = _trained(predictor, ckpt, paths, digests, renders, recipe, progress)
        prior = em_prior(after)
    else:
        if recipe.probe and recipe.method != "stack" and len(paths) < FEW_PHOTOS:
            log.warning("%d unlabelled photos: on fewer than %d, the probe judged photos it had not seen 2 to 21 points "
                        "worse than the model on both measured parts, and the photos it adapted on within 2 points "
                        "(docs/reference.md)", len(paths), FEW_PHOTOS)
        labels = np.concatenate([y, np.full(len(paths), -1)]) if known else None
        adapter, before, after, choice = fit_on(predictor, known + paths, recipe, labels,
                                                sessions + ["unlabelled"] * len(paths))
        adapted, prior = with_adapter(ckpt, adapter, digests, known_digests), adapter.prior
    threshold = predictor.cfg.threshold
    seconds = time.perf_counter() - start
    result = Adapted(out / checkpoint.MODEL_FILE, len(known) + len(paths), prior, float((before >= threshold).mean()),
                     float((after >= threshold).mean()), seconds, len(known), None if networks else choice)
    log.info("adapted (%s) on %d photos (%d labelled) in %.1f s: estimated %.0f %% deformed; judged deformed "
             "%.0f %% -> %.0f %%", recipe.method, result.photos, len(known), seconds, 100 * prior,
             100 * result.deformed_before, 100 * result.deformed_after)
    with replacing(out, identity, "model") as tmp:
        checkpoint.write(tmp / checkpoint.MODEL_FILE, adapted)
        made(AdaptFile, {"model": str(path), "groups": groups, "recipe": asdict(recipe),
                         "folders": {k: None if v is None else str(v) for k, v in sources.items()},
                         "protocol": "unlabelled photos' labels never read",
                         **{k: v for k, v in asdict(result).items() if k != "model_path"}}).write(tmp / "adapt.json")
    return result


def _trained(predictor, ckpt: dict, paths: list[str], digests: list[str], renders, recipe: AdaptRecipe,
             progress: bool) -> tuple[dict, np.ndarray, np.ndarray]:
    """The saved model ``ckpt`` (``predictor`` of it) with its networks trained on the unlabelled ``paths``
    (:mod:`deformsim.learn.fixmatch`) beside the ``renders``, recording their ``digests``; the photos' P(deformed)
    before and after."""
    from deformsim.learn.fixmatch import MatchRecipe, self_trained
    from deformsim.learn.predict import Predictor

    adapted = self_trained(ckpt, predictor.path, paths, renders, MatchRecipe(steps=recipe.steps, method=recipe.method),
                           progress)
    adapted["adapted_unlabelled"] = sorted(set(ckpt.get("adapted_unlabelled", [])) | set(digests))
    return adapted, predictor.predict_outputs(paths), Predictor(adapted, predictor.path, progress).predict_outputs(paths)

