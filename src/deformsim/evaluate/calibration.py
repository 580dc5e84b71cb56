"""Calibration of P(deformed): the bins of a reliability diagram and the expected calibration error. Pure numpy."""

from __future__ import annotations

import numpy as np

from deformsim.errors import UserError
from deformsim.evaluate.metrics import _check


def reliability(y_true, prob, n_bins: int = 10) -> dict:
    """Equal-width bins of the predicted P(deformed) over [0, 1], and the expected calibration error.

    Bin ``i`` holds the probabilities in [i / n_bins, (i + 1) / n_bins), the last one 1 too. Each bin gives its
    edges ``lo`` and ``hi``, its number of images ``n``, their mean predicted probability ``prob`` and the share
    of them that is deformed ``freq`` (both None when the bin is empty). ``ece`` is the sum over bins of
    n / N * |freq - prob|. Returns ``{"n", "ece", "bins"}``.
    """
    if n_bins < 1:
        raise UserError(f"a reliability diagram needs at least 1 bin, got {n_bins}")
    y, p = _check(y_true, prob, 0.5)
    which = np.minimum((p * n_bins).astype(int), n_bins - 1)
    bins, ece = [], 0.0
    for i in range(n_bins):
        mine = which == i
        n = int(mine.sum())
        mean_p = float(p[mine].mean()) if n else None
        freq = float(y[mine].mean()) if n else None
        if n:
            ece += n / y.size * abs(freq - mean_p)
        bins.append({"lo": i / n_bins, "hi": (i + 1) / n_bins, "n": n, "prob": mean_p, "freq": freq})
    return {"n": int(y.size), "ece": ece, "bins": bins}
