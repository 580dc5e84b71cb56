"""The results file of a benchmark: one schema for every command that reads one, a one-line refusal naming the first
bad value (missing keys, wrong types, NaN or out-of-range numbers, ragged predictions, duplicated runs, nesting too
deep), and the schema version its writers record."""

from __future__ import annotations

import copy
import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from deformsim.evaluate.benchmark import aggregate
from deformsim.evaluate.results import SCHEMA_VERSION, read_results
from tests.evaluate.test_combine import _results


@pytest.fixture
def good():
    rng = np.random.default_rng(0)
    y = (rng.random(40) < 0.6).astype(int)
    return _results(rng.random((4, 40)), y)


def _bench(tmp_path, *args):
    from deformsim.cli.app import app

    return CliRunner().invoke(app, ["bench", *map(str, args)])


def _write(path, data) -> object:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def _one_line(res) -> str:
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert res.exit_code in (1, 2) and len(lines) == 1 and lines[0].startswith("error:"), res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    return lines[0]


def _edited(good, edit):
    bad = copy.deepcopy(good)
    edit(bad)
    return bad


EDITS = {
    "missing predictions": (lambda r: r["runs"][0].pop("real_predictions"), r"runs\[0\].real_predictions: Field required"),
    "missing runs": (lambda r: r.pop("runs"), "runs: Field required"),
    "missing threshold": (lambda r: r["settings"]["train"].pop("threshold"), "settings.train.threshold"),
    "labels of text": (lambda r: r.update(real_labels="abc"), "real_labels"),
    "a prediction of text": (lambda r: r["runs"][1]["real_predictions"].__setitem__(3, "0.5"),
                             r"runs\[1\].real_predictions\[3\]"),
    "ragged predictions": (lambda r: r["runs"][2]["real_predictions"].pop(),
                           r"runs\[2\] .* holds 39 predictions for 40 photos"),
    "an integer variant": (lambda r: r["runs"][0].update(variant=3), r"runs\[0\].variant"),
    "a list of runs of lists": (lambda r: r.update(runs=[[1, 2]]), r"runs\[0\]"),
    "a seed of text": (lambda r: r["runs"][0].update(train_seed="0"), r"runs\[0\].train_seed"),
    "a string file": (lambda r: r.clear(), "Field required"),
}


@pytest.mark.parametrize("command", ["merge", "mean", "bag", "compare"])
@pytest.mark.parametrize("case", sorted(EDITS))
def test_a_hand_made_results_file_is_refused_in_one_line(good, tmp_path, command, case):
    edit, match = EDITS[case]
    bad = _write(tmp_path / "bad" / "results.json", _edited(good, edit))
    ok = _write(tmp_path / "ok" / "results.json", good)
    args = {"merge": ("merge", bad, ok, "--out", tmp_path / "o"), "mean": ("mean", ok, bad, "--out", tmp_path / "o"),
            "bag": ("bag", bad, "--members", "2", "--out", tmp_path / "o"),
            "compare": ("compare", ok, "--baseline", bad)}[command]
    line = _one_line(_bench(tmp_path, *args))
    assert str(bad) in line
    assert re.search(match, line), line
    assert not (tmp_path / "o").exists()


def test_deep_nesting_is_one_line(tmp_path, good):
    deep = _write(tmp_path / "deep.json", "[" * 100_000 + "]" * 100_000)
    assert "nested too deeply" in _one_line(_bench(tmp_path, "bag", deep, "-k", "2", "--out", tmp_path / "o"))
    inner = json.dumps(good)[:-1] + ', "plan": ' + "[" * 5000 + "]" * 5000 + "}"
    deep = _write(tmp_path / "inner.json", inner)
    assert "nested too deeply" in _one_line(_bench(tmp_path, "compare", deep, "--baseline", deep))


@pytest.mark.parametrize("value, shown", [(float("nan"), "nan"), (-5, "-5"), (1.5, "1.5"), (1e308, "1e+308"),
                                          (float("inf"), "inf")])
@pytest.mark.parametrize("command", ["compare", "bag"])
def test_a_bad_prediction_is_refused_showing_it(good, tmp_path, value, shown, command):
    bad = _write(tmp_path / "bad.json", _edited(good, lambda r: r["runs"][1]["real_predictions"].__setitem__(7, value)))
    ok = _write(tmp_path / "ok.json", good)
    args = ("compare", bad, "--baseline", ok) if command == "compare" else ("bag", bad, "-k", "2", "--out", tmp_path / "o")
    line = _one_line(_bench(tmp_path, *args))
    assert "runs[1].real_predictions[7]" in line and f"got {shown})" in line, line


def test_compare_refuses_a_nan_threshold_and_duplicated_runs(good, tmp_path):
    ok = _write(tmp_path / "ok.json", good)
    nan = _write(tmp_path / "nan.json", _edited(good, lambda r: r["settings"]["train"].update(threshold=float("nan"))))
    assert "settings.train.threshold" in _one_line(_bench(tmp_path, "compare", nan, "--baseline", ok))
    twice = _write(tmp_path / "twice.json", _edited(good, lambda r: r["runs"].append(copy.deepcopy(r["runs"][0]))))
    line = _one_line(_bench(tmp_path, "compare", ok, "--baseline", twice))
    assert "runs[4] is a second run of variant backgrounds, data seed 0, background seed 0, training seed 0" in line


def test_writers_record_the_schema_version_and_older_files_still_read(good, tmp_path):
    assert "schema_version" not in good  # as files from before the version was written
    ok = _write(tmp_path / "ok" / "results.json", good)
    res = _bench(tmp_path, "bag", ok, "-k", "2", "--out", tmp_path / "bagged")
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "bagged" / "results.json").read_text())["schema_version"] == SCHEMA_VERSION
    newer = _write(tmp_path / "new.json", good | {"schema_version": SCHEMA_VERSION + 1})
    assert "schema_version" in _one_line(_bench(tmp_path, "compare", newer, "--baseline", ok))


def test_a_results_file_round_trips_with_its_undefined_scores(good, tmp_path):
    """What a writer builds reads back the same, an AUC undefined on one class (NaN in a spread) included."""
    from deformsim.evaluate.combine import mean
    from tests.evaluate.test_combine import loaded

    combined = mean([loaded(good), loaded(good)], ["a", "b"])
    combined.runs[0].real.auc = None  # as compute_metrics gives it without both classes
    combined.variants = aggregate(combined.runs)
    assert np.isnan(combined.variants["backgrounds"].auc_mean)
    combined.write(tmp_path / "results.json")
    again = read_results(tmp_path)
    assert json.dumps(again.dump(), sort_keys=True) == json.dumps(combined.dump(), sort_keys=True)
    assert again.dump()["plan"] == {"mean of": ["a", "b"], "whole": False} and again.schema_version == 1


@pytest.mark.parametrize("edit, said", [
    (lambda r: r.update(schema_version=SCHEMA_VERSION + 1), r"has schema_version 2, newer than this deformsim reads \(1\)"),
    (lambda r: r.update(surprise=1), "surprise: Extra inputs are not permitted"),
    (lambda r: r["runs"][0]["real"].update(accuracy=1.5), r"runs\[0\].real.accuracy: Input should be less than or equal"),
])
def test_a_newer_or_foreign_results_file_is_refused_in_one_line(good, tmp_path, edit, said):
    from deformsim.errors import UserError

    path = _write(tmp_path / "results.json", _edited(good, edit))
    with pytest.raises(UserError, match=said) as err:
        read_results(tmp_path)
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)


def test_a_results_file_from_before_the_auc_still_combines(good, tmp_path):
    """Files written before 2026-12-03 have no AUC in their runs, spreads and ensembles: merge, mean, bag and compare
    read them."""
    from deformsim.evaluate.combine import mean

    old = _edited(good, lambda r: [run["real"].pop("auc") for run in r["runs"]])
    old["variants"] = {"backgrounds": {"n_runs": 4, **{f"{k}_{s}": 0.5 for k in ("accuracy", "f1", "precision", "recall",
                                                     "synthetic_accuracy", "synthetic_f1") for s in ("mean", "std")}}}
    old["ensembles"] = {"backgrounds": {"n_draws": 2, "members": 2, **{f"{k}_{s}": 0.5 for k in (
        "accuracy", "f1", "precision", "recall") for s in ("mean", "std")}}}
    path = _write(tmp_path / "old" / "results.json", old)
    read = read_results(path)
    assert read.runs[0].real.auc is None and read.variants["backgrounds"].auc_mean is None
    assert mean([read, read], ["a", "b"]).variants["backgrounds"].auc_mean is not None  # scored again
    res = _bench(tmp_path, "compare", path, "--baseline", path)
    assert res.exit_code == 0 and "Difference to" in res.output, res.output
