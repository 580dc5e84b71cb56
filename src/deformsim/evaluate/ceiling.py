"""The real-to-real ceiling (``deformsim bench ceiling``): how well each backbone's frozen ImageNet features separate
the classes of a labelled folder of real photos, by a logistic regression cross-validated inside the folder.

Per backbone and input size: the photos (one per content) pass the whole frozen network (its pooled features, the
ImageNet layers ``train.finetune`` would train included), are standardised over the folder, and a logistic
regression (:func:`deformsim.learn.adapter.fit_logistic`) trained on ``folds - 1`` folds scores the last, for each
fold in turn (a seeded permutation, stratified by class). What it measures is the representation, not a model to
ship: a backbone whose features cannot separate the photos even with their labels leaves nothing for adapting to
them, labelled or not (:mod:`deformsim.learn.adapter`). Labels are used inside this cross-validation only.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from deformsim.errors import UserError
from deformsim.evaluate.ceiling_file import CeilingFile
from deformsim.log import get_logger
from deformsim.records import made

log = get_logger(__name__)


def _folds(y: np.ndarray, folds: int, seed: int) -> np.ndarray:
    """A fold per photo, each class spread evenly over the folds (seeded)."""
    rng = np.random.default_rng(seed)
    fold = np.empty(len(y), dtype=int)
    for c in (0, 1):
        rows = np.flatnonzero(y == c)
        fold[rng.permutation(rows)] = np.arange(len(rows)) % folds
    return fold


def frozen_features(backbone: str, size: int, paths: list[str], batch_size: int = 16) -> tuple[np.ndarray, str]:
    """Pooled features (N, D) of ``paths`` through the whole frozen ImageNet network ``backbone`` at ``size`` px, and
    where its weights came from."""
    import torch

    from deformsim.config import TrainConfig
    from deformsim.learn.features import cached_stem
    from deformsim.learn.models import build

    net, weights = build(TrainConfig(backbone=backbone, image_size=size))
    net.eval()
    stems = cached_stem(net, paths, size, batch_size)
    with torch.inference_mode():
        return torch.cat([net.pooled_raw(z) for z in stems.split(batch_size)]).double().numpy(), weights


def cross_validated(x: np.ndarray, y: np.ndarray, folds: int, l2: float, seed: int) -> np.ndarray:
    """Each photo's P(deformed) from the regression fitted on the other folds."""
    from deformsim.learn.adapter import fit_logistic, sigmoid

    x = (x - x.mean(0)) / (x.std(0) + 1e-6)
    fold, p = _folds(y, folds, seed), np.empty(len(y))
    for f in range(folds):
        test = fold == f
        coef, bias = fit_logistic(x[~test], y[~test].astype(float), np.ones((~test).sum()), l2)
        p[test] = sigmoid(x[test] @ coef + bias)
    return p


def run_ceiling(real: Path, out: Path, backbones: list[str], sizes: list[int], folds: int = 5, l2: float = 0.1,
                seed: int = 0) -> CeilingFile:
    """Every backbone at every size on the labelled photos of ``real``; written to ``out/ceiling.json`` and
    returned."""
    from deformsim.evaluate.fewshot import unique_photos
    from deformsim.evaluate.metrics import compute_metrics
    from deformsim.learn.backbones import BACKBONES
    from deformsim.outputs import check_folder_target

    start = time.perf_counter()
    out = check_folder_target(out, "--out")
    unknown = [b for b in backbones if b not in BACKBONES]
    if unknown or not backbones:
        raise UserError(f"--backbones {','.join(backbones)}: choose from {', '.join(BACKBONES)}")
    if not sizes or not all(32 <= s <= 1024 for s in sizes):
        raise UserError(f"--sizes {','.join(map(str, sizes))}: each must lie in [32, 1024]")
    if not 2 <= folds <= 20:
        raise UserError(f"--folds must lie in [2, 20], got {folds}")
    table = unique_photos(real)
    y = table["y"].to_numpy()
    if min(y.sum(), (1 - y).sum()) < folds:
        raise UserError(f"{real}: {folds} folds need at least {folds} photos of each class")
    paths = list(table["path"])
    rows = []
    for backbone in backbones:
        for size in sizes:
            began = time.perf_counter()
            features, weights = frozen_features(backbone, size, paths)
            per_photo = (time.perf_counter() - began) / len(paths)
            p = cross_validated(features, y, folds, l2, seed)
            m = compute_metrics(y, p, 0.5)
            rows.append({"backbone": backbone, "size": size, "weights": weights, "features": features.shape[1],
                         "accuracy": m["accuracy"], "f1": m["f1"], "auc": m["auc"], "seconds_per_photo": per_photo})
            log.info("%s at %d px: cross-validated accuracy %.3f, AUC %s", backbone, size, m["accuracy"], m["auc"])
    result = made(CeilingFile, {"real": str(real), "photos": len(paths), "folds": folds, "l2": l2, "seed": seed,
                                "majority": float(max(y.mean(), 1 - y.mean())), "rows": rows,
                                "seconds": time.perf_counter() - start})
    out.mkdir(parents=True, exist_ok=True)
    result.write(out / "ceiling.json")
    return result
