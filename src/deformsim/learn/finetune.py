"""Fine-tuning a trained model with a handful of labelled real photos (``deformsim finetune``).

The frozen stem stays frozen. What adapts is the head (``part="head"``) or the head and the backbone's trainable
tail, the layers ``deformsim train`` trained (``part="tail"``). Each photo enters as its plain image and ``views``
augmented views (:func:`deformsim.learn.data.augmenter`), each put through the stem once (the plain one from the
feature cache); with ``part="head"`` their pooled features are computed once too, so a step trains the head alone.
Each step draws (a seeded ``torch.Generator``) a batch of photos, one view of each, mixed with as many synthetic
images when some are given, so the model keeps what it learnt; the learning rate is small. BatchNorm statistics
stay as trained (a handful of photos cannot estimate them); the head's dropout is on. Every network of the model
adapts this way on its own stem's features: an ensemble's members and each backbone's model
(``train.ensemble_backbones``); the loss logged is their mean per step.

The saved model lists the sha256 of every photo it was adapted on (``adapted_on``): evaluate, report and the
benchmarks refuse to score it on any of them, a renamed copy included (:func:`check_unseen`).

With ``unlabelled`` photos (their labels never read) the fine-tuned model then adapts to them as ``deformsim adapt
--photos`` does (:mod:`deformsim.learn.adapt_stage`, the default method), the labelled photos joining that fit with
their labels; it records those photos too (``adapted_unlabelled``).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from torch import nn

from deformsim.atomic import write_json
from deformsim.errors import UserError
from deformsim.identity import digest, file_digest
from deformsim.learn.device import adam
from deformsim.learn.models import DeformNet, members
from deformsim.log import get_logger
from deformsim.schema import MAX_SEED, shown

log = get_logger(__name__)

PARTS = ("head", "tail")


@dataclass(frozen=True)
class Recipe:
    """How a model adapts: what trains, for how many steps, how fast, on how many augmented views per photo."""

    part: str = "tail"
    steps: int = 100
    lr: float = 1e-4
    batch_size: int = 16  # photos per step, and as many synthetic images
    views: int = 4  # augmented views per photo, beside its plain image
    seed: int = 0

    def __post_init__(self) -> None:
        if self.part not in PARTS:
            raise UserError(f"finetune part must be one of {', '.join(PARTS)}, got {self.part!r}")
        for name, low, high in (("steps", 1, 100_000), ("batch_size", 1, 4096), ("views", 0, 64)):
            if not low <= getattr(self, name) <= high:
                raise UserError(f"finetune {name} must lie in [{low}, {high}], got {getattr(self, name)}")
        if not 0 < self.lr <= 1:
            raise UserError(f"finetune lr must lie in (0, 1], got {self.lr}")
        if not (isinstance(self.seed, int) and 0 <= self.seed <= MAX_SEED):
            raise UserError(f"--seed {shown(self.seed)}: a seed is a whole number from 0 to {MAX_SEED}")


def check_unseen(model: str | Path, paths: Iterable[str | Path]) -> None:
    """Refuse with one line to score ``model`` (model.pt or its folder, already read by
    :func:`deformsim.learn.checkpoint.read_checkpoint`) on an image it was fine-tuned on, by content: a renamed
    copy too; warn that the score is transductive when it adapted to some of them unlabelled."""
    from deformsim.learn.checkpoint import MODEL_FILE

    path = Path(model) / MODEL_FILE if Path(model).is_dir() else Path(model)
    ckpt = torch.load(path, map_location="cpu", weights_only=True, mmap=True)
    seen, unlabelled = set(ckpt.get("adapted_on", [])), set(ckpt.get("adapted_unlabelled", []))
    digests = [file_digest(p) for p in paths] if seen or unlabelled else []
    hits = [p for p, d in zip(paths, digests) if d in seen]
    if hits:
        raise UserError(f"{model} learnt from the labels of {len(hits)} of these images (by content), e.g. {hits[0]}: "
                        "score it on photos it has not seen")
    if (shared := sum(d in unlabelled for d in digests)):
        log.warning("transductive: %s adapted to %d of these %d images, labels unread (deformsim adapt)", model,
                    shared, len(digests))


@torch.no_grad()
def part_inputs(model: DeformNet, stems: torch.Tensor, part: str, batch_size: int) -> torch.Tensor:
    """What the training part reads: the stem activations (``tail``), or their pooled features through the frozen
    tail (``head``), in the leading shape of ``stems``."""
    if part == "tail":
        return stems
    was_training = model.training
    model.eval()
    flat = stems.flatten(0, stems.dim() - 4)
    pooled = torch.cat([model.pooled_raw(b.to(model.mean.device)).cpu() for b in flat.split(batch_size)])
    model.train(was_training)
    return pooled.view(*stems.shape[:-3], -1)


def part_logits(model: DeformNet, x: torch.Tensor, part: str) -> torch.Tensor:
    """Logits of P(deformed) from what the training ``part`` reads (:func:`part_inputs`)."""
    return model.tail(x) if part == "tail" else model.head(model.norm(x)).squeeze(1)


def adapt(model: DeformNet, photos: torch.Tensor, y: torch.Tensor, recipe: Recipe,
          synthetic: tuple[torch.Tensor, torch.Tensor] | None = None) -> list[float]:
    """Train ``model`` in place on ``photos`` (:func:`part_inputs` of :func:`deformsim.learn.views.photo_views`:
    views x N x ...) with labels ``y`` (N,), each batch mixed with as many of the ``synthetic`` (inputs, labels); the
    loss of each step."""
    if model.target != "label":
        raise UserError(f"fine-tuning needs a model of train.target label, not {model.target}")
    device = model.mean.device
    params = [p for p in (model.parameters() if recipe.part == "tail" else model.head.parameters()) if p.requires_grad]
    opt = adam(params, recipe.lr)
    order = torch.Generator().manual_seed(recipe.seed)
    y = y.float()
    losses = []
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(recipe.seed)  # the head's dropout draws from here
        model.eval()
        model.head.train()
        for _ in range(recipe.steps):
            rows = torch.randperm(photos.shape[1], generator=order)[: recipe.batch_size]
            view = torch.randint(photos.shape[0], (len(rows),), generator=order)
            x, target = photos[view, rows], y[rows]
            if synthetic is not None:
                more = torch.randperm(len(synthetic[1]), generator=order)[: recipe.batch_size]
                x, target = torch.cat([x, synthetic[0][more]]), torch.cat([target, synthetic[1][more].float()])
            loss = nn.functional.binary_cross_entropy_with_logits(part_logits(model, x.to(device), recipe.part),
                                                                  target.to(device))
            opt.zero_grad()
            loss.backward()
            opt.step()
            losses.append(loss.item())
    model.eval()
    return losses


@dataclass
class Finetuned:
    """A fine-tuned model in its folder: what it adapted on, and the loss of its first and last step."""

    model_path: Path
    photos: int
    synthetic: int
    seconds: float
    loss: tuple[float, float]
    unlabelled: int = 0  # the unlabelled photos it then adapted to (their labels unread)


def finetune(model: Path, real: Path, out: Path, recipe: Recipe = Recipe(), data: Path | None = None,
             variant: str | None = None, overwrite: bool = False, progress: bool = True,
             unlabelled: Path | None = None) -> Finetuned:
    """Adapt the trained ``model`` on the labelled photos in ``real`` (intact/ and deformed/), mixed with the
    images of ``data`` (a dataset's ``variant``, or a photo folder) when given, then to the ``unlabelled`` photos
    when given; save it into the folder ``out``.

    Refused with one line before any work when ``real`` is missing, empty or holds one class, when ``unlabelled``
    is refused as ``deformsim adapt --photos`` refuses it, when the model is not a label classifier or is adapted
    already (``deformsim adapt``), or when ``out`` is refused as ``deformsim train`` refuses it (and when it holds
    the model or the photos, or lies inside the photos).
    """
    from deformsim.dataset.real import real_table
    from deformsim.dataset.tables import check_table
    from deformsim.learn import checkpoint
    from deformsim.learn.adapt_stage import unlabelled_photos
    from deformsim.learn.device import pick_device, set_threads
    from deformsim.learn.features import cached_stem
    from deformsim.learn.stage import images_digest, model_renders
    from deformsim.learn.views import photo_views
    from deformsim.outputs import check_apart, check_folder_target, check_outside, claim, replacing

    start = time.perf_counter()
    out = check_folder_target(out, "--out")
    ckpt, path = checkpoint.read_checkpoint(model)
    cfg = checkpoint.saved_config(ckpt, path)
    if cfg.target != "label":
        raise UserError(f"{path} predicts train.target {cfg.target}: fine-tuning needs a label classifier")
    photos = real_table(real)
    check_table(photos, f"--real {real}")
    if variant is not None and data is None:
        raise UserError(f"--variant {variant} needs --data (the synthetic images to mix in)")
    synthetic = model_renders(data, variant, path, cfg) if data is not None else None
    if ckpt.get("adapter") is not None:  # fine-tuning keeps the networks, not an adapter fitted to their old outputs
        raise UserError(f"{path} is adapted already: fine-tune the model it was made from")
    extra, extra_digests = unlabelled_photos(unlabelled, "--unlabelled") if unlabelled is not None else ([], [])
    check_apart(out, "--out", {"model": path, "real photos": real, "synthetic data": data, "unlabelled photos": unlabelled})
    check_outside(out, "--out", {"real photos": real, "unlabelled photos": unlabelled})
    identity = {"settings": {"finetune": asdict(recipe)},
                "inputs": {"model": file_digest(path), "real": images_digest(photos, real),
                           "data": None if synthetic is None else images_digest(synthetic, data), "variant": variant,
                           **({"unlabelled": digest(extra_digests)} if unlabelled is not None else {})}}
    claim(out, "model", identity, overwrite)

    set_threads()
    device = pick_device(cfg.device)
    models = [checkpoint.restore(ckpt, path), *checkpoint.restore_mixture(ckpt, path)]
    paths = list(photos["path"])
    y, y_mix = torch.tensor(photos["y"].to_numpy()), None if synthetic is None else torch.tensor(synthetic["y"].to_numpy())
    curves = []
    for k, (net, _) in enumerate(models):  # each backbone's model (train.ensemble_backbones), on its own stem
        if len(models) > 1:
            log.info("backbone %s (%d of %d)", net.backbone, k + 1, len(models))
        net.to(device)
        views = photo_views(net, paths, cfg.image_size, recipe.views, recipe.seed, cfg.batch_size, progress, cfg.crop)
        stems = None
        if synthetic is not None:
            stems = cached_stem(net, list(synthetic["path"]), cfg.image_size, cfg.batch_size, progress)
        for member in members(net):  # an ensemble's members adapt one by one
            mix = None if stems is None else (part_inputs(member, stems, recipe.part, cfg.batch_size), y_mix)
            curves.append(adapt(member, part_inputs(member, views, recipe.part, cfg.batch_size), y, recipe, mix))
    losses = torch.tensor(curves).mean(0).tolist()  # per step, the mean over the members and backbones
    adapted_on = sorted(set(ckpt.get("adapted_on", [])) | {file_digest(p) for p in paths})
    seconds = time.perf_counter() - start
    log.info("fine-tuned the %s on %d photos%s in %.1f s: loss %.3f -> %.3f", recipe.part, len(paths),
             "" if synthetic is None else f" and {len(synthetic)} synthetic images", seconds, losses[0], losses[-1])
    with replacing(out, identity, "model") as tmp:
        mixture = [(m, c, e.get("weights", "")) for (m, c), e in zip(models[1:], ckpt.get("mixture", []))]
        tuned = checkpoint.contents(models[0][0], cfg, ckpt.get("weights", ""), ckpt.get("history", []),
                                    ckpt.get("split", {}), adapted_on=adapted_on, mixture=mixture)
        if unlabelled is not None:
            tuned, extra = _adapt_unlabelled(tuned, path, paths, photos["y"].to_numpy(), extra, extra_digests,
                                             progress)
        checkpoint.write(tmp / checkpoint.MODEL_FILE, tuned)
        write_json(tmp / "finetune.json", {
            "model": str(path), "real": str(real), "photos": len(paths), "n_deformed": int(photos["y"].sum()),
            "data": None if data is None else str(data), "variant": variant,
            "synthetic": 0 if synthetic is None else len(synthetic), "recipe": asdict(recipe), "losses": losses,
            "unlabelled": None if unlabelled is None else str(unlabelled), "unlabelled_photos": len(extra),
            "seconds": time.perf_counter() - start})
    return Finetuned(out / checkpoint.MODEL_FILE, len(paths), 0 if synthetic is None else len(synthetic),
                     time.perf_counter() - start, (losses[0], losses[-1]), len(extra))


def _adapt_unlabelled(tuned: dict, path: Path, labelled: list[str], y, paths: list[str], digests: list[str],
                      progress: bool) -> tuple[dict, list[str]]:
    """The fine-tuned model ``tuned`` (made from ``path``) adapted to the unlabelled ``paths`` (less the copies of a
    ``labelled`` photo, which join the fit with their labels ``y``), and the unlabelled photos used."""
    import numpy as np

    from deformsim.learn.adapt_stage import fit_on, not_labelled, with_adapter
    from deformsim.learn.adapter import AdaptRecipe
    from deformsim.learn.predict import Predictor

    paths, digests = not_labelled(paths, digests, [file_digest(p) for p in labelled])
    labels = np.concatenate([np.asarray(y), np.full(len(paths), -1)])
    adapter = fit_on(Predictor(tuned, path, progress), labelled + paths, AdaptRecipe(), labels)[0]
    log.info("adapted to %d unlabelled photos: estimated %.0f %% deformed", len(paths), 100 * adapter.prior)
    return with_adapter(tuned, adapter, digests), paths
