"""Binary classification metrics with *deformed* as the positive class. Pure numpy.

A probability at or above the threshold predicts *deformed*. A ratio whose denominator is zero (precision
with no positive prediction, recall with no deformed image, F1 when precision + recall is zero) is given as 0
and named in ``undefined`` when nothing defines it (no positive prediction; no deformed image; neither), so a
reader can show "-". ``auc``, the area under the ROC curve, does not depend on the threshold (None without
both classes). ``interval`` holds 95 % Wilson score intervals of accuracy (the right share of the images),
precision (of the images predicted deformed), recall (of the deformed images) and F1, which is the proportion
TP / (TP + (FP + FN) / 2). Wilson's interval stays sane where a percentile bootstrap collapses: 8 images all right
give F1 51-100 %, not 100-100 %.
"""

from __future__ import annotations

import numpy as np

from deformsim.dataset.images import CLASSES
from deformsim.errors import UserError


def _ratio(num: float, den: float) -> float:
    return float(num / den) if den else 0.0


Z95 = 1.959964  # the normal quantile of a two-sided 95 % interval


def wilson_interval(successes: float, n: float, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a proportion ``successes / n`` (95 % by default; ``n`` may be a half count, as F1's
    is); (0, 1) when ``n`` is 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return float(max(0.0, min(p, centre - half))), float(min(1.0, max(p, centre + half)))  # p in it, rounding aside


def f1_interval(tp: int, fp: int, fn: int) -> tuple[float, float] | None:
    """95 % Wilson interval of F1 = TP / (TP + (FP + FN) / 2); None when F1 is undefined (no TP, FP or FN)."""
    if tp + fp + fn == 0:
        return None
    return wilson_interval(tp, tp + (fp + fn) / 2)


def roc_auc(prob: np.ndarray, deformed: np.ndarray) -> np.ndarray:
    """Area under the ROC curve of each row of ``prob`` (..., images) against the bool labels ``deformed``: the chance
    that a deformed image scores above an intact one (ties count half), whatever the threshold; NaN without both
    classes."""
    prob = np.asarray(prob, dtype=float)
    pos, neg = prob[..., deformed][..., :, None], prob[..., ~deformed][..., None, :]
    if pos.shape[-2] == 0 or neg.shape[-1] == 0:
        return np.full(prob.shape[:-1], np.nan)
    return (pos > neg).mean((-2, -1)) + 0.5 * (pos == neg).mean((-2, -1))


def _check(y_true, prob, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y_true)
    p = np.asarray(prob, dtype=float)
    if y.ndim != 1 or p.shape != y.shape:
        raise UserError(f"labels and probabilities must be 1-D and equally long, got {y.shape} and {p.shape}")
    if y.size == 0:
        raise UserError("no images to evaluate")
    bad = set(np.unique(y).tolist()) - {0, 1}
    if bad:
        raise UserError(f"labels must be 0 (intact) or 1 (deformed), got {sorted(bad)}")
    if not np.all(np.isfinite(p)) or p.min() < 0 or p.max() > 1:
        raise UserError(f"probabilities must lie in [0, 1], got range [{np.nanmin(p)}, {np.nanmax(p)}]")
    if not 0 < threshold < 1:
        raise UserError(f"threshold must lie in (0, 1), got {threshold}")
    return y.astype(int), p


def confusion_matrix(y_true, y_pred) -> np.ndarray:
    """``[[TN, FP], [FN, TP]]``: rows are the true class, columns the predicted class (intact, deformed)."""
    y, p = np.asarray(y_true, dtype=int), np.asarray(y_pred, dtype=int)
    cm = np.zeros((2, 2), dtype=int)
    np.add.at(cm, (y, p), 1)
    return cm


def compute_metrics(y_true, prob, threshold: float = 0.5) -> dict:
    """Accuracy, precision, recall, F1, the confusion matrix of ``prob >= threshold`` against ``y_true``, the names
    of the undefined ratios and their 95 % intervals (None for an undefined one)."""
    y, p = _check(y_true, prob, threshold)
    pred = (p >= threshold).astype(int)
    cm = confusion_matrix(y, pred)
    (tn, fp), (fn, tp) = cm.tolist()
    precision, recall = _ratio(tp, tp + fp), _ratio(tp, tp + fn)
    f1 = f1_interval(tp, fp, fn)
    return {
        "n": int(y.size),
        "n_deformed": int(y.sum()),
        "threshold": float(threshold),
        "accuracy": _ratio(tp + tn, y.size),
        "precision": precision,
        "recall": recall,
        "f1": _ratio(2 * precision * recall, precision + recall),
        "auc": None if np.isnan(auc := float(roc_auc(p, y == 1))) else auc,
        "undefined": [k for k, den in (("precision", tp + fp), ("recall", tp + fn), ("f1", tp + fp + fn)) if not den],
        "interval": {"accuracy": list(wilson_interval(tp + tn, int(y.size))), "f1": None if f1 is None else list(f1),
                     "precision": list(wilson_interval(tp, tp + fp)) if tp + fp else None,
                     "recall": list(wilson_interval(tp, tp + fn)) if tp + fn else None},
        "confusion": {
            "matrix": cm.tolist(),
            "rows": [f"true {c}" for c in CLASSES],
            "cols": [f"predicted {c}" for c in CLASSES],
        },
    }
