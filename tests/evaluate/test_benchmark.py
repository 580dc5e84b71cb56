"""The sim-to-real benchmark's aggregation and plan checks (no training)."""

from __future__ import annotations

import pytest

from deformsim.errors import UserError
from deformsim.evaluate.benchmark import Plan, aggregate, format_table


def _run(variant, acc, f1, prec, rec, synth):
    return {"variant": variant, "real": {"accuracy": acc, "f1": f1, "precision": prec, "recall": rec},
            "synthetic": {"accuracy": synth, "f1": synth}}


def test_aggregate_gives_mean_and_sample_std_per_variant():
    runs = [_run("backgrounds", 0.6, 0.5, 1.0, 0.4, 0.9), _run("backgrounds", 0.8, 0.7, 0.8, 0.6, 0.95),
            _run("backgrounds", 0.7, 0.9, 0.9, 0.8, 1.0), _run("black", 0.5, 0.3, 1.0, 0.2, 0.92)]
    s = aggregate(runs)
    assert list(s) == ["backgrounds", "black"]
    bg = s["backgrounds"]
    assert bg["n_runs"] == 3
    # by hand: mean 0.7; deviations -0.1, 0.1, 0 -> sample variance 0.02 / 2 = 0.01 -> std 0.1
    assert bg["accuracy_mean"] == pytest.approx(0.7) and bg["accuracy_std"] == pytest.approx(0.1)
    assert bg["f1_mean"] == pytest.approx(0.7) and bg["f1_std"] == pytest.approx(0.2)
    assert bg["precision_mean"] == pytest.approx(0.9) and bg["precision_std"] == pytest.approx(0.1)
    assert bg["recall_mean"] == pytest.approx(0.6) and bg["recall_std"] == pytest.approx(0.2)
    assert bg["synthetic_accuracy_mean"] == pytest.approx(0.95) and bg["synthetic_accuracy_std"] == pytest.approx(0.05)
    assert s["black"]["n_runs"] == 1 and s["black"]["accuracy_std"] == 0.0


def test_table_shows_every_variant_and_the_baseline():
    text = format_table(aggregate([_run("backgrounds", 0.6, 0.5, 1.0, 0.4, 0.9), _run("backgrounds", 0.8, 0.7, 0.8, 0.6, 0.95)]),
                        baseline=0.623)
    assert "| backgrounds | 2 | 0.700 ± 0.141 |" in text
    assert "baseline on the real photos: accuracy 0.623" in text


@pytest.mark.parametrize("kwargs", [{"train_seeds": 0}, {"composite_seeds": -1}, {"variants": ()}])
def test_bad_plans_fail_with_one_line(kwargs):
    with pytest.raises(UserError, match="benchmark"):
        Plan(**kwargs)
