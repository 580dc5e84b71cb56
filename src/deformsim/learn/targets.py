"""Heads on the dense labels (``train.target``), trained on the frozen backbone.

The whole backbone is frozen, so what a head reads is computed once per image from the cached stem activations
(pooled features for severity and family, the stem's map for localise) and every epoch trains only the head:

- ``severity``: smooth L1 on the manifest's ``max_disp_mm``, standardised by the training images' mean and std;
- ``family``: binary cross-entropy per ``family_<name>`` column (multi-label);
- ``localise``: binary cross-entropy + soft Dice on the ``region`` masks, area-resized to the head's output.

The split, seeds and files are those of :func:`deformsim.learn.train.fit`; the history's ``score`` is
:data:`SCORES` of the target (mean absolute error in mm, micro F1, pooled IoU at ``train.threshold``).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from PIL import Image
from torch import nn

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.device import adam
from deformsim.learn.heads import region_size
from deformsim.learn.models import DeformNet
from deformsim.log import get_logger, progress_bar

log = get_logger(__name__)

FAMILY_PREFIX = "family_"
SCORES = {"severity": "mae_mm", "family": "f1", "localise": "iou"}
_HINT = "a dataset generated with render.dense: true"


def family_columns(table: pd.DataFrame) -> list[str]:
    return [c for c in table.columns if c.startswith(FAMILY_PREFIX)]


def output_names(table: pd.DataFrame, target: str) -> list[str]:
    """What the model's outputs are: the families of a ``family`` model, else one name."""
    if target == "family":
        return [c.removeprefix(FAMILY_PREFIX) for c in family_columns(table)]
    return {"label": ["deformed"], "severity": ["max_disp_mm"], "localise": ["region"]}[target]


def check_target(table: pd.DataFrame, cfg: TrainConfig) -> None:
    """A :class:`UserError` unless ``table`` carries the labels ``cfg.target`` trains on (and they are usable)."""
    target = cfg.target
    if target == "label":
        return
    for name in ("augment", "random_conv"):
        if getattr(cfg, name):
            raise UserError(f"train.{name} does not apply to train.target {target} (its heads train on cached features)")
    need = {"severity": ["max_disp_mm"], "family": family_columns(table) or ["family_<name>"], "localise": ["region"]}
    missing = [c for c in need[target] if c not in table.columns]
    if missing:
        raise UserError(f"train.target {target} needs {_HINT}: the image table has no {missing[0]} column")
    if target == "severity" and not np.isfinite(table["max_disp_mm"].to_numpy(dtype=float)).all():
        raise UserError("train.target severity: max_disp_mm has missing or infinite values")
    if target == "localise":
        gone = [p for p in table["region"] if not Path(p).is_file()]
        if gone:
            raise UserError(f"train.target localise: {len(gone)} region mask(s) missing, e.g. {gone[0]}")


def region_masks(paths: list[str], size: int) -> torch.Tensor:
    """Region (or mask) images as 0/1 float maps (N, size, size): the share of the cell covered, at least half."""
    out = np.zeros((len(paths), size, size), np.float32)
    for i, p in enumerate(paths):
        with Image.open(p) as im:
            out[i] = np.asarray(im.convert("L").resize((size, size), Image.BOX)) >= 128
    return torch.from_numpy(out)


def labels(table: pd.DataFrame, cfg: TrainConfig) -> torch.Tensor:
    """The training targets of ``cfg.target`` for every row: mm (N,), 0/1 families (N, K) or masks (N, s, s)."""
    if cfg.target == "severity":
        return torch.tensor(table["max_disp_mm"].to_numpy(dtype="float32"))
    if cfg.target == "family":
        return torch.tensor(table[family_columns(table)].to_numpy(dtype="float32"))
    return region_masks(list(table["region"]), region_size(cfg.image_size))


def _loss(model: DeformNet, out: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    if model.target == "severity":
        return nn.functional.smooth_l1_loss(out / model.scale[1], y / model.scale[1])
    bce = nn.functional.binary_cross_entropy_with_logits(out, y)
    if model.target == "family":
        return bce
    p = torch.sigmoid(out)
    return bce + 1 - (2 * (p * y).sum() + 1) / (p.sum() + y.sum() + 1)


def _score(target: str, out: torch.Tensor, y: torch.Tensor, threshold: float) -> float:
    """Mean absolute error (mm), micro F1 of the families, or IoU of the region pixels pooled over images."""
    if target == "severity":
        return float((out - y).abs().mean())
    pred, truth = torch.sigmoid(out) >= threshold, y >= 0.5
    both, either = float((pred & truth).sum()), float((pred | truth).sum())
    if target == "family":
        return 2 * both / (float(pred.sum()) + float(truth.sum())) if either else 1.0
    return both / either if either else 1.0


def _measure(model: DeformNet, h: torch.Tensor, y: torch.Tensor, rows: torch.Tensor,
             cfg: TrainConfig) -> tuple[float | None, float | None]:
    if len(rows) == 0:
        return None, None
    model.eval()
    with torch.no_grad():
        out = torch.cat([model.from_input(h[b]) for b in rows.split(cfg.batch_size)])
        return float(_loss(model, out, y[rows])), _score(cfg.target, out, y[rows], cfg.threshold)


def fit_head(model: DeformNet, stems: torch.Tensor, table: pd.DataFrame, train_rows: torch.Tensor,
             val_rows: torch.Tensor, cfg: TrainConfig, progress: bool) -> list[dict]:
    """Train ``model``'s head for ``cfg.target`` on the stem activations of every row; the per-epoch history."""
    device = stems.device
    model.eval()
    with torch.no_grad():
        h = torch.cat([model.head_input(z) for z in stems.split(cfg.batch_size)])
    y = labels(table, cfg).to(device)
    train_rows, val_rows = train_rows.to(device), val_rows.to(device)
    if cfg.target == "severity":
        known = y[train_rows]
        std = float(known.std()) if len(known) > 1 else 0.0
        model.scale.copy_(torch.tensor([float(known.mean()), std if std > 1e-6 else 1.0]))
    opt = adam([p for p in model.parameters() if p.requires_grad], cfg.lr)
    order = torch.Generator().manual_seed(cfg.seed)
    torch.manual_seed(cfg.seed)  # dropout draws from here
    history = []
    with progress_bar(cfg.epochs, "epochs", progress) as bar:
        for epoch in range(1, cfg.epochs + 1):
            t0 = time.perf_counter()
            model.train()
            for batch in train_rows[torch.randperm(len(train_rows), generator=order).to(device)].split(cfg.batch_size):
                if cfg.feature_norm and len(batch) < 2:
                    continue  # batch statistics need two images
                loss = _loss(model, model.from_input(h[batch]), y[batch])
                opt.zero_grad()
                loss.backward()
                opt.step()
            loss, score = _measure(model, h, y, train_rows, cfg)
            val_loss, val_score = _measure(model, h, y, val_rows, cfg)
            history.append({"epoch": epoch, "loss": loss, "score": score, "val_loss": val_loss, "val_score": val_score,
                            "metric": SCORES[cfg.target], "seconds": time.perf_counter() - t0})
            bar.update()
            log.debug("epoch %d/%d: loss %.3f, %s %.3f, validation %s %s", epoch, cfg.epochs, loss, SCORES[cfg.target],
                      score, SCORES[cfg.target], "-" if val_score is None else f"{val_score:.3f}")
    return history
