"""Paired comparison of benchmarks: zero against itself, a real gain clears its interval, noise does not."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.paired import compare, ensembles, scores
from deformsim.evaluate.results import Difference, ResultsFile
from tests.evaluate import test_combine


def _results(prob: np.ndarray, y: np.ndarray, variant: str = "backgrounds") -> ResultsFile:
    """Two draws of two training seeds of ``variant``, run 2 * draw + seed predicting row ``prob``."""
    results = test_combine._results(prob, y)
    for run in results["runs"]:
        run["variant"] = variant
    return test_combine.loaded(results)


@pytest.fixture
def photos():
    rng = np.random.default_rng(0)
    y = (rng.random(77) < 0.6).astype(int)
    prob = np.clip(y + rng.normal(0, 0.45, (4, 77)), 0, 1)  # about 0.85 accurate
    return prob, y


def test_scores_agree_with_compute_metrics(photos):
    prob, y = photos
    s = scores(prob, y, 0.5)
    for r in range(4):
        m = compute_metrics(y, prob[r], 0.5)
        for k in ("accuracy", "f1", "precision", "recall", "auc"):
            assert s[k][r] == pytest.approx(m[k])


def test_a_run_against_itself_differs_by_zero(photos):
    prob, y = photos
    c = compare(_results(prob, y), _results(prob, y))["backgrounds"]
    assert c.pairs == 4
    for part in (c.runs, c.ensemble):
        for d in part.values():
            assert d == Difference(diff=0.0, low=0.0, high=0.0, clears=False)
    ens = ensembles(_results(prob, y))["backgrounds"].accuracy_mean  # what ensembling adds to the single runs
    assert c.ensemble_vs_single["accuracy"].diff == pytest.approx(ens - scores(prob, y, 0.5)["accuracy"].mean())


def test_a_clear_gain_clears_and_noise_does_not(photos):
    prob, y = photos
    better = np.where(y == 1, np.maximum(prob, 0.9), np.minimum(prob, 0.1))  # every photo right
    gain = compare(_results(better, y), _results(prob, y))["backgrounds"].runs["accuracy"]
    assert gain.clears and gain.low > 0 and gain.diff == pytest.approx(1 - scores(prob, y, 0.5)["accuracy"].mean())
    rng = np.random.default_rng(1)
    flipped = prob.copy()
    for r in range(4):  # two photos each way per run: no real difference
        right = np.nonzero((prob[r] >= 0.5) == y)[0]
        wrong = np.nonzero((prob[r] >= 0.5) != y)[0]
        flipped[r, rng.choice(right, 2, replace=False)] = 1 - prob[r, rng.choice(right, 2, replace=False)]
        flipped[r, rng.choice(wrong, 2, replace=False)] = 1 - prob[r, rng.choice(wrong, 2, replace=False)]
    noise = compare(_results(flipped, y), _results(prob, y))["backgrounds"].runs["accuracy"]
    assert not noise.clears and noise.low < 0 < noise.high


def test_other_photos_or_no_pairs_are_one_line(photos):
    prob, y = photos
    other = _results(prob, y)
    other.real_paths[0] = "/photos/intact/renamed.jpg"
    with pytest.raises(UserError, match="scored on other photos"):
        compare(_results(prob, y), other)
    base = _results(prob, y)
    for r in base.runs:
        r.train_seed += 10
    with pytest.raises(UserError, match="no run of variant backgrounds has a baseline run"):
        compare(_results(prob, y), base)


def test_runs_pair_by_seeds_when_the_baseline_trained_another_variant(photos):
    prob, y = photos
    c = compare(_results(prob, y, "surface"), _results(prob, y, "backgrounds"))["surface"]
    assert c.pairs == 4 and c.baseline_variant == "backgrounds" and c.runs["f1"].diff == 0


def test_ensemble_averages_each_draws_training_seeds(photos):
    prob, y = photos
    e = ensembles(_results(prob, y))["backgrounds"]
    draws = [scores(prob[2 * d : 2 * d + 2].mean(0, keepdims=True), y, 0.5)["accuracy"][0] for d in range(2)]
    assert e.n_draws == 2 and e.members == 2
    assert e.spread("accuracy") == pytest.approx((np.mean(draws), np.std(draws, ddof=1)))
