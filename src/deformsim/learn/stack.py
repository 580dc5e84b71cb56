"""A few labelled photos added to a trained model without letting them mislead it (``deformsim adapt --labelled``).

The adapted logit is the synthetic model's logit plus a logistic *residual* on the photos' pooled features
(standardised over every photo given, labelled or not), fitted to the labelled photos with the synthetic logit as
offset: the renders stay the anchor and the photos only correct it (stacking with a fixed prior; Wolpert 1992). The
residual's L2 penalty is chosen by cross-validation inside the labelled photos (class-balanced held-out log-loss)
from a grid that starts with no residual at all, by the one-standard-error rule (Hastie, Tibshirani, Friedman 2009,
§7.10): the most regularised choice within one standard error of the best.

Folds are shooting sessions when the labelled photos carry more than one (:mod:`deformsim.dataset.groups`): each
session is held out in turn, and a fold counts only when its training part holds both classes. When none does (each
session one class, as when the dented parts were all shot one afternoon) the model stays the synthetic one: a
residual fitted there would learn the session, not the dent. Photos of one session, or undated, are split into
:data:`FOLDS` class-stratified folds, and with fewer than that many photos of a class the model stays as it is: with
fewer folds the one-standard-error rule rests on too few held-out losses, and a residual chosen on a handful of
photos can follow whatever else sets their classes apart (``bench adapt --biased``: with 2 photos per class, each
class from another lighting, it fell below the model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deformsim.errors import UserError
from deformsim.learn.adapter import Adapter, fit_logistic, logit, sigmoid

L2_GRID = (100.0, 10.0, 1.0, 0.1)  # residual penalties tried, most regularised first (after "none")
FOLDS = 5  # class-stratified folds of labelled photos from one session; fewer photos of a class: no residual


@dataclass(frozen=True)
class Choice:
    """What cross-validation chose: the penalty (``None``: no residual), the folds it used and why none when so."""

    l2: float | None
    folds: int
    losses: dict[str, float]  # mean held-out log-loss per candidate ("none", then each penalty)
    reason: str = ""


def folds_of(labels: np.ndarray, groups: list[str]) -> tuple[list[np.ndarray], str]:
    """Held-out index sets over the labelled photos (``labels`` 0/1), and why there are none when so."""
    sessions = sorted(set(groups))
    if len(sessions) > 1:
        held = [np.flatnonzero(np.asarray(groups) == s) for s in sessions]
        usable = [h for h in held if len(set(np.delete(labels, h))) == 2]
        if not usable:
            return [], (f"each of the {len(sessions)} shooting sessions of the labelled photos holds one class: a "
                        "residual fitted on them would learn the session")
        return usable, ""
    fewest = int(min((labels == c).sum() for c in (0, 1)))
    if fewest < FOLDS:
        return [], f"cross-validation needs {FOLDS} labelled photos of each class ({FOLDS} folds)"
    fold = np.empty(len(labels), dtype=int)
    for c in (0, 1):
        rows = np.flatnonzero(labels == c)
        fold[rows] = np.arange(len(rows)) % FOLDS
    return [np.flatnonzero(fold == f) for f in range(FOLDS)], ""


def _weights(y: np.ndarray) -> np.ndarray:
    """Each class weighing half, whatever its count."""
    return np.where(y == 1, 0.5 / max(y.sum(), 1), 0.5 / max((1 - y).sum(), 1)) * len(y)


def _loss(y: np.ndarray, z: np.ndarray) -> float:
    """Class-balanced log-loss of logits ``z``: the mean over the classes present of each class's mean loss."""
    nll = np.logaddexp(0, -z) * y + np.logaddexp(0, z) * (1 - y)
    return float(np.mean([nll[y == c].mean() for c in (0, 1) if (y == c).any()]))


def choose(x: np.ndarray, offset: np.ndarray, y: np.ndarray, groups: list[str]) -> Choice:
    """The residual penalty by cross-validation over :data:`L2_GRID` and no residual, one-standard-error rule."""
    held, reason = folds_of(y, groups)
    if not held:
        return Choice(None, 0, {}, reason)
    names = ["none", *map(str, L2_GRID)]
    losses = np.zeros((len(names), len(held)))
    for f, test in enumerate(held):
        train = np.setdiff1d(np.arange(len(y)), test)
        losses[0, f] = _loss(y[test], offset[test])
        for i, l2 in enumerate(L2_GRID, 1):
            coef, bias = fit_logistic(x[train], y[train], _weights(y[train]), l2, offset[train])
            losses[i, f] = _loss(y[test], offset[test] + x[test] @ coef + bias)
    mean = losses.mean(1)
    best = int(np.argmin(mean))
    se = float(losses[best].std(ddof=1) / np.sqrt(len(held))) if len(held) > 1 else 0.0
    pick = next(i for i in range(len(names)) if mean[i] <= mean[best] + se)
    return Choice(None if pick == 0 else L2_GRID[pick - 1], len(held), dict(zip(names, mean.round(6).tolist())))


def fit_stack(p: np.ndarray, features: np.ndarray, labels: np.ndarray, groups: list[str]) -> tuple[Adapter, Choice]:
    """The stacked adapter of photos with synthetic probabilities ``p`` and pooled ``features`` (N, D), of which
    those with ``labels`` 0/1 (-1: unlabelled) are the user's labelled ones, in shooting sessions ``groups``."""
    labels = np.asarray(labels)
    known = labels >= 0
    if not {0, 1} <= set(labels[known].tolist()):
        raise UserError("--labelled needs photos of both classes (intact/ and deformed/)")
    x = np.asarray(features, dtype=np.float64)
    mean, scale = x.mean(0), x.std(0) + 1e-6
    x = (x - mean) / scale
    offset, y = logit(p), labels.astype(np.float64)
    choice = choose(x[known], offset[known], y[known], [g for g, k in zip(groups, known) if k])
    coef, bias, kept = np.zeros(0), 0.0, ([], [])
    if choice.l2 is not None:
        coef, bias = fit_logistic(x[known], y[known], _weights(y[known]), choice.l2, offset[known])
        kept = (mean.tolist(), scale.tolist())
    share = float(sigmoid(offset + (x @ coef + bias if len(coef) else 0.0)).mean())
    adapter = Adapter("stack", share, 0.0, 1.0, *kept, coef.tolist(), float(bias), len(p), int(known.sum()))
    return adapter, choice
