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
RESAMPLE_BUDGET = 1_000_000  # resampled values held at once (8 MB per array of them)


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


def resample_blocks(n_boot: int, width: int) -> list[int]:
    """``n_boot`` resamples of ``width`` values each, split into blocks of at most :data:`RESAMPLE_BUDGET` values
    (at least one resample per block); drawing the blocks in turn draws the same numbers as drawing all at once."""
    per = max(1, RESAMPLE_BUDGET // max(width, 1))
    return [min(per, n_boot - start) for start in range(0, n_boot, per)]


def roc_auc(prob: np.ndarray, deformed: np.ndarray) -> np.ndarray:
    """Area under the ROC curve of each row of ``prob`` (..., images) against the bool labels ``deformed`` (broadcast
    to ``prob``'s shape): the chance that a deformed image scores above an intact one (ties count half), whatever the
    threshold; NaN without both classes. The Mann-Whitney statistic, counted on the sorted rows: O(n log n) each."""
    prob = np.asarray(prob, dtype=float)
    pos = np.broadcast_to(np.asarray(deformed, dtype=bool), prob.shape)
    n = prob.shape[-1]
    if n == 0:
        return np.full(prob.shape[:-1], np.nan)
    order = np.argsort(prob, axis=-1)
    ordered, pos = np.take_along_axis(prob, order, -1), np.take_along_axis(pos, order, -1)
    at = np.broadcast_to(np.arange(n), prob.shape)
    change = ordered[..., 1:] != ordered[..., :-1]
    edge = np.ones(prob.shape[:-1] + (1,), dtype=bool)
    first = np.maximum.accumulate(np.where(np.concatenate([edge, change], -1), at, 0), axis=-1)  # of its tie
    end = np.flip(np.minimum.accumulate(np.flip(np.where(np.concatenate([change, edge], -1), at + 1, n), -1), -1), -1)
    zero = np.zeros(prob.shape[:-1] + (1,), dtype=np.int64)
    neg_before = np.concatenate([zero, np.cumsum(~pos, axis=-1)], -1)  # intact images among the first k
    below = np.take_along_axis(neg_before, first, -1)  # intact images scored below each one
    tied = np.take_along_axis(neg_before, end, -1) - below
    n_pos = pos.sum(-1)
    pairs = (n_pos * (n - n_pos)).astype(float)
    above, ties = np.where(pos, below, 0).sum(-1), np.where(pos, tied, 0).sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(pairs > 0, above / pairs + 0.5 * (ties / pairs), np.nan)


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
    outside = np.flatnonzero(~((p >= 0) & (p <= 1)))  # NaN fails both
    if outside.size:
        raise UserError(f"probabilities must lie in [0, 1], got {p[outside[0]]} (image {outside[0]}; "
                        f"{outside.size} outside)")
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
