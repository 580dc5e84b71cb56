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

from deformsim.atomic import write_json
from deformsim.errors import UserError
from deformsim.identity import digest, file_digest
from deformsim.learn.adapter import MIN_PHOTOS, Adapter, AdaptRecipe, fit_adapter
from deformsim.log import get_logger

log = get_logger(__name__)


@dataclass
class Adapted:
    """An adapted model in its folder, the photos it adapted on, their estimated share of deformed parts and the
    share judged deformed before and after adapting."""

    model_path: Path
    photos: int
    prior: float
    deformed_before: float
    deformed_after: float
    seconds: float


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


def fit_on(predictor, paths: list[str], recipe: AdaptRecipe) -> tuple[Adapter, np.ndarray, np.ndarray]:
    """The adapter of ``predictor`` (:class:`deformsim.learn.predict.Predictor`, not adapted yet) fitted on
    ``paths``, and the photos' probabilities before and after adapting."""
    check_adaptable(predictor)
    p, features = predictor.outputs_and_features(paths, recipe.probe)
    adapter = fit_adapter(p, features, recipe)
    return adapter, p, adapter.apply(p, features)


def adapt_model(model: Path, photos: Path, out: Path, recipe: AdaptRecipe = AdaptRecipe(), overwrite: bool = False,
                progress: bool = True) -> Adapted:
    """Adapt ``model`` to the unlabelled ``photos`` and save it into the folder ``out`` (``model.pt``, ``adapt.json``).

    Refused with one line before any work: see :func:`unlabelled_photos`; a model that is not a label classifier or
    is adapted already; ``out`` refused as ``deformsim train`` refuses it, or holding the model or the photos.
    """
    from deformsim.learn import checkpoint
    from deformsim.learn.predict import Predictor
    from deformsim.outputs import check_apart, check_folder_target, check_outside, claim, replacing

    start = time.perf_counter()
    out = check_folder_target(out, "--out")
    ckpt, path = checkpoint.read_checkpoint(model)
    paths, digests = unlabelled_photos(photos)
    check_apart(out, "--out", {"model": path, "photos": photos})
    check_outside(out, "--out", {"photos": photos})
    predictor = Predictor(ckpt, path, progress)
    check_adaptable(predictor)
    identity = {"settings": {"adapt": asdict(recipe)},
                "inputs": {"model": file_digest(path), "photos": digest(digests)}}
    claim(out, "model", identity, overwrite)
    adapter, before, after = fit_on(predictor, paths, recipe)
    threshold = predictor.cfg.threshold
    seconds = time.perf_counter() - start
    result = Adapted(out / checkpoint.MODEL_FILE, len(paths), adapter.prior, float((before >= threshold).mean()),
                     float((after >= threshold).mean()), seconds)
    log.info("adapted (%s) on %d photos in %.1f s: estimated %.0f %% deformed; judged deformed %.0f %% -> %.0f %%",
             recipe.method, len(paths), seconds, 100 * adapter.prior, 100 * result.deformed_before,
             100 * result.deformed_after)
    with replacing(out, identity, "model") as tmp:
        adapted = dict(ckpt, adapter=adapter.to_dict(),
                       adapted_unlabelled=sorted(set(ckpt.get("adapted_unlabelled", [])) | set(digests)))
        checkpoint.write(tmp / checkpoint.MODEL_FILE, adapted)
        write_json(tmp / "adapt.json", {"model": str(path), "photos": str(photos), "recipe": asdict(recipe),
                                         "protocol": "unlabelled: labels never read",
                                         **{k: v for k, v in asdict(result).items() if k != "model_path"}})
    return result

