"""Metrics of the dense-label heads, pure numpy: severity, deformation families, region masks.

- severity: mean absolute error and RMSE in mm, Spearman's rank correlation, and the error of always answering
  the training images' mean (the baseline a model must beat);
- family: per family average precision (area under the precision-recall steps), F1, precision and recall at
  the threshold, and their macro means over the families with a positive image;
- region: intersection over union and pixel F1 pooled over all test pixels, and the mean IoU per image over the
  images where truth or prediction has a region pixel.
"""

from __future__ import annotations

import numpy as np

from deformsim.evaluate.metrics import compute_metrics


def _ranks(x: np.ndarray) -> np.ndarray:
    """Ranks from 1, ties sharing their mean rank."""
    order = np.argsort(x, kind="stable")
    ranks = np.empty(len(x))
    ranks[order] = np.arange(1, len(x) + 1)
    _, inverse, counts = np.unique(x, return_inverse=True, return_counts=True)
    sums = np.bincount(inverse, weights=ranks)
    return (sums / counts)[inverse]


def spearman(a, b) -> float | None:
    """Spearman's rho of two equally long sequences; None when either is constant or shorter than 2."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 2 or np.ptp(a) == 0 or np.ptp(b) == 0:
        return None
    return float(np.corrcoef(_ranks(a), _ranks(b))[0, 1])


def severity_metrics(true, pred, train_mean: float) -> dict:
    true, pred = np.asarray(true, float), np.asarray(pred, float)
    err = pred - true
    return {"n": int(len(true)), "mae_mm": float(np.abs(err).mean()), "rmse_mm": float(np.sqrt((err ** 2).mean())),
            "spearman": spearman(true, pred), "baseline_mae_mm": float(np.abs(true - train_mean).mean())}


def average_precision(y, score) -> float | None:
    """Average precision of ``score`` ranking the positives of ``y`` first; None without a positive."""
    y, score = np.asarray(y, bool), np.asarray(score, float)
    if not y.any():
        return None
    order = np.argsort(-score, kind="stable")
    hits = y[order]
    precision = np.cumsum(hits) / np.arange(1, len(y) + 1)
    return float(precision[hits].sum() / hits.sum())


def family_metrics(y, prob, names: list[str], threshold: float) -> dict:
    """Per-family and macro metrics of probabilities ``prob`` (N, K) against 0/1 ``y`` (N, K)."""
    y, prob = np.asarray(y, bool), np.asarray(prob, float)
    per = {}
    for k, name in enumerate(names):
        m = compute_metrics(y[:, k].astype(int), prob[:, k], threshold)
        per[name] = {"ap": average_precision(y[:, k], prob[:, k]), "f1": m["f1"], "precision": m["precision"],
                     "recall": m["recall"], "n_positive": int(y[:, k].sum())}
    scored = [m for m in per.values() if m["n_positive"]]
    return {"n": int(len(y)), "threshold": float(threshold), "families": per,
            "macro_ap": float(np.mean([m["ap"] for m in scored])) if scored else None,
            "macro_f1": float(np.mean([m["f1"] for m in scored])) if scored else None}


def region_metrics(truth, prob, threshold: float) -> dict:
    """IoU and pixel F1 of ``prob >= threshold`` against the bool masks ``truth`` (N, H, W)."""
    truth, pred = np.asarray(truth, bool), np.asarray(prob, float) >= threshold
    inter, union = (truth & pred).sum((1, 2)), (truth | pred).sum((1, 2))
    total = int(truth.sum() + pred.sum())
    seen = union > 0
    return {"n": int(len(truth)), "threshold": float(threshold),
            "iou": float(inter.sum() / union.sum()) if union.sum() else 1.0,
            "pixel_f1": float(2 * inter.sum() / total) if total else 1.0,
            "mean_iou": float((inter[seen] / union[seen]).mean()) if seen.any() else 1.0,
            "truth_fraction": float(truth.mean()), "predicted_fraction": float(pred.mean())}
