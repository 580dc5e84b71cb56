"""Benchmarks combined after the fact: merged draws pool their runs, a mean is scored on the mean probabilities, and
a bag scores blocks of consecutive training seeds as the ensembles train.ensemble trains."""

from __future__ import annotations

import json

import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.combine import bag, mean, merge
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.paired import METRICS, compare
from deformsim.evaluate.results import ResultsFile


def _results(prob: np.ndarray, y: np.ndarray, data_seeds=(0, 1), threshold: float = 0.5, seeds: int = 2) -> dict:
    """A benchmark of one variant: ``seeds`` training seeds per data seed, row k of ``prob`` the k-th run's
    predictions."""
    runs = []
    for k, (d, t) in enumerate((d, t) for d in data_seeds for t in range(seeds)):
        m = compute_metrics(y, prob[k], threshold)
        runs.append({"variant": "backgrounds", "data_seed": d, "composite_seed": 0, "train_seed": t,
                     "model": f"models/{d}-{t}",
                     "real": {k: m[k] for k in METRICS} | {"confusion": m["confusion"]["matrix"]},
                     "synthetic": {"accuracy": 0.9, "f1": 0.8 + 0.02 * t}, "real_predictions": prob[k].tolist()})
    return {"runs": runs, "real_labels": y.tolist(), "settings": {"train": {"threshold": threshold}},
            "real_paths": [f"/photos/{'deformed' if v else 'intact'}/{i}.jpg" for i, v in enumerate(y)],
            "real_dir": "/photos", "real_images": len(y), "majority_baseline": 0.6}


def loaded(results: dict) -> ResultsFile:
    """``results`` as a command reads them from their file."""
    return ResultsFile.model_validate_json(json.dumps(results))


def _loaded(*args, **kwargs) -> ResultsFile:
    return loaded(_results(*args, **kwargs))


@pytest.fixture
def photos():
    rng = np.random.default_rng(0)
    y = (rng.random(40) < 0.6).astype(int)
    return rng.random((4, 40)), y


def test_merged_draws_pool_their_runs(photos):
    prob, y = photos
    a, b = _loaded(prob, y, (0, 1)), _loaded(prob[::-1], y, (2, 3))
    merged = merge([a, b], ["a", "b"])
    assert len(merged.runs) == 8
    accuracy = [r.real.accuracy for r in a.runs + b.runs]
    assert merged.variants["backgrounds"].accuracy_mean == pytest.approx(np.mean(accuracy))
    assert merged.ensembles["backgrounds"].n_draws == 4
    c = compare(merged, merged)["backgrounds"]
    assert c.pairs == 8 and all(c.runs[k].diff == 0 for k in METRICS)


def test_the_same_run_twice_is_one_line_naming_both(photos):
    prob, y = photos
    with pytest.raises(UserError, match=r"^a and b both hold the run of variant backgrounds, data seed 0"):
        merge([_loaded(prob, y), _loaded(prob, y, (0, 5))], ["a", "b"])


def test_merging_other_settings_is_one_line_naming_the_first_difference(photos):
    prob, y = photos
    a, b = _results(prob, y), _results(prob, y, (2, 3))
    b["settings"] = {"train": {"threshold": 0.5, "backbone": "efficientnet_lite0", "seed": 7},
                     "generate": {"seed": 2}}
    with pytest.raises(UserError, match=r"b was made with other settings than a \(train.backbone: efficientnet_lite0 "
                                        r"against vgg16\)"):
        merge([loaded(a), loaded(b)], ["a", "b"])
    del b["settings"]["train"]["backbone"]  # other seeds only: other draws of one config
    assert len(merge([loaded(a), loaded(b)], ["a", "b"]).runs) == 8
    b["plan"] = {"whole": True}  # its models trained on every render, a's on a split of them
    with pytest.raises(UserError, match=r"b was made with other settings than a \(whole: True against False\)"):
        merge([loaded(a), loaded(b)], ["a", "b"])
    a["plan"] = {"whole": True}
    assert merge([loaded(a), loaded(b)], ["a", "b"]).plan.whole is True


def test_the_mean_of_a_benchmark_and_itself_is_itself(photos):
    prob, y = photos
    a = _loaded(prob, y)
    same = mean([a, a], ["a", "a"])
    assert [r.real_predictions for r in same.runs] == [r.real_predictions for r in a.runs]
    assert same.variants["backgrounds"].accuracy_mean == pytest.approx(np.mean([r.real.accuracy for r in a.runs]))


def test_the_mean_is_scored_on_the_mean_probabilities(photos):
    _, y = photos
    # each model errs narrowly on its own half of the photos and is sure and right on the other's
    half = np.arange(len(y)) < len(y) // 2
    right, narrowly_wrong = np.where(y == 1, 0.9, 0.1), np.where(y == 1, 0.45, 0.55)
    first, second = np.where(half, narrowly_wrong, right), np.where(half, right, narrowly_wrong)
    a, b = _loaded(np.tile(first, (4, 1)), y), _loaded(np.tile(second, (4, 1)), y)
    both = mean([a, b], ["a", "b"])
    run = both.runs[0]
    assert run.real.accuracy == 1.0 and a.runs[0].real.accuracy == 0.5
    assert run.real_predictions == pytest.approx(((first + second) / 2).tolist())
    assert run.synthetic.f1 == pytest.approx(0.8) and run.model == ["models/0-0", "models/0-0"]


def test_only_runs_paired_in_every_benchmark_are_kept(photos):
    prob, y = photos
    both = mean([_loaded(prob, y, (0, 1)), _loaded(prob, y, (1, 2))], ["a", "b"])
    assert {r.data_seed for r in both.runs} == {1}
    with pytest.raises(UserError, match="no run of a has a run with the same variant and seeds"):
        mean([_loaded(prob, y, (0, 1)), _loaded(prob, y, (2, 3))], ["a", "b"])


def test_other_photos_another_threshold_or_one_input_is_one_line(photos):
    prob, y = photos
    with pytest.raises(UserError, match="b was scored on other photos"):
        merge([_loaded(prob, y), _loaded(prob, 1 - y, (2, 3))], ["a", "b"])
    with pytest.raises(UserError, match="b scores at threshold 0.4, a at 0.5"):
        mean([_loaded(prob, y), _loaded(prob, y, threshold=0.4)], ["a", "b"])
    with pytest.raises(UserError, match="two or more"):
        merge([_loaded(prob, y)], ["a"])


def test_cli_writes_the_combined_results_and_never_over_an_input(photos, tmp_path):
    from typer.testing import CliRunner

    from deformsim.cli.app import app

    prob, y = photos
    for name, seeds in (("a", (0, 1)), ("b", (2, 3))):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.json").write_text(json.dumps(_results(prob, y, seeds) | {"created": name}))
    before = (tmp_path / "a" / "results.json").read_text()
    res = CliRunner().invoke(app, ["bench", "merge", str(tmp_path / "a"), str(tmp_path / "b"), "--out",
                                   str(tmp_path / "a")])
    assert res.exit_code != 0 and "is an input of this command" in res.output
    assert (tmp_path / "a" / "results.json").read_text() == before
    res = CliRunner().invoke(app, ["bench", "merge", str(tmp_path / "a"), str(tmp_path / "b"), "--out",
                                   str(tmp_path / "ab")])
    assert res.exit_code == 0, res.output
    assert "over 8 runs" in res.output and (tmp_path / "ab" / "report.html").is_file()
    assert len(json.loads((tmp_path / "ab" / "results.json").read_text())["runs"]) == 8
    res = CliRunner().invoke(app, ["bench", "bag", str(tmp_path / "ab"), "--members", "2", "--out", str(tmp_path / "k2")])
    assert res.exit_code == 0, res.output
    assert len(json.loads((tmp_path / "k2" / "results.json").read_text())["runs"]) == 4


def test_a_bag_scores_each_block_of_consecutive_seeds_on_its_mean_probabilities():
    rng = np.random.default_rng(1)
    y = (rng.random(40) < 0.6).astype(int)
    prob = rng.random((10, 40))
    bagged = bag(_loaded(prob, y, (0, 1), seeds=5), 2, "a")  # per draw seeds 0-1 and 2-3; seed 4 has no block
    assert [(r.data_seed, r.train_seed) for r in bagged.runs] == [(0, 0), (0, 2), (1, 0), (1, 2)]
    for run, rows in zip(bagged.runs, ([0, 1], [2, 3], [5, 6], [7, 8])):
        mean_prob = prob[rows].mean(0)
        np.testing.assert_allclose(run.real_predictions, mean_prob)
        assert run.real.accuracy == pytest.approx(np.mean((mean_prob >= 0.5) == y))
        assert run.synthetic.f1 == pytest.approx(0.81 if run.train_seed == 0 else 0.85)
    assert bagged.dump()["plan"] == {"bagged": ["a"], "whole": False, "members": 2}
    assert bagged.ensembles["backgrounds"].members == 4  # seeds 0-3 of each draw
    c = compare(bagged, bagged)["backgrounds"]
    assert c.pairs == 4 and all(c.runs[k].diff == 0 for k in METRICS)
    with pytest.raises(UserError, match=r"^a has no draw with 6 consecutive training seeds: run it with --train-seeds 6"):
        bag(_loaded(prob, y, (0, 1), seeds=5), 6, "a")
    with pytest.raises(UserError, match=r"--members must lie in \[2, 16\], got 1"):
        bag(_loaded(prob, y, (0, 1), seeds=5), 1, "a")
