"""Binary classification metrics with *deformed* as the positive class. Pure numpy.

A probability at or above the threshold predicts *deformed*. A ratio whose denominator is zero (precision
with no positive prediction, recall with no deformed image, F1 when precision + recall is zero) is defined
as 0.
"""

from __future__ import annotations

import numpy as np

from deformsim.dataset.images import CLASSES
from deformsim.errors import UserError


def _ratio(num: float, den: float) -> float:
    return float(num / den) if den else 0.0


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
    """Accuracy, precision, recall, F1 and the confusion matrix of ``prob >= threshold`` against ``y_true``."""
    y, p = _check(y_true, prob, threshold)
    cm = confusion_matrix(y, (p >= threshold).astype(int))
    (tn, fp), (fn, tp) = cm.tolist()
    precision, recall = _ratio(tp, tp + fp), _ratio(tp, tp + fn)
    return {
        "n": int(y.size),
        "n_deformed": int(y.sum()),
        "threshold": float(threshold),
        "accuracy": _ratio(tp + tn, y.size),
        "precision": precision,
        "recall": recall,
        "f1": _ratio(2 * precision * recall, precision + recall),
        "confusion": {
            "matrix": cm.tolist(),
            "rows": [f"true {c}" for c in CLASSES],
            "cols": [f"predicted {c}" for c in CLASSES],
        },
    }
