"""Results on stdout: the end-of-run summary of `run`, `report` and `bench sim2real`, and piped `predict` lines."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from deformsim.api import Engine, Prediction
from deformsim.cli.app import app
from deformsim.pipeline import RunResult
from tests.report.made import experiment, metrics_file


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def write_report(folder):
    """A report folder whose black model got 7 of 10 real photos right and whose procedural one predicted none
    deformed (precision undefined)."""
    y = [0] * 6 + [1] * 4
    black = experiment(y, [0.1] * 5 + [0.9] + [0.9] * 2 + [0.1] * 2, "models/black_full/model.pt")
    procedural = experiment(y, [0.1] * 10, "models/procedural_full/model.pt")
    folder.mkdir(parents=True)
    (folder / "metrics.json").write_text(json.dumps(metrics_file({
        "black": {"n_images": 10, "real": black, "split": {"skipped": "too few samples"}},
        "procedural": {"n_images": 10, "real": procedural},
    })))
    (folder / "report.html").write_text("<html></html>")
    return folder / "report.html"


def test_a_runs_stdout_ends_with_the_summary_table(monkeypatch, tmp_path):
    report = write_report(tmp_path / "run" / "report")
    run = tmp_path / "run"
    seconds = {"generate": 5.0, "report: training": 2.0, "report: testing, plots and the page": 1.0}
    monkeypatch.setattr(Engine, "run", lambda self, out, real, **kw: RunResult(
        run, run / "data", report, seconds, ["composite:procedural"], run / "model"))
    res = invoke("run", "--out", run)
    assert res.exit_code == 0, res.output
    lines = res.stdout.strip().splitlines()
    assert lines[:4] == ["time per stage:", *(f"  {name:<36} {secs:7.1f} s" for name, secs in seconds.items())]
    assert lines[1].index("5.0") == lines[3].index("1.0")  # one column however long the stage's name
    assert lines[4] == "  up to date, skipped: composite:procedural"
    assert lines[-3:] == [f"report: {report}", f"Results saved to {run}",  # whole, however long the path
                          f"predict with its model: deformsim predict {run / 'model'} PHOTOS..."]
    table = "\n".join(lines[lines.index(next(line for line in lines if "Results (" in line)):])
    for heading in ("trained on", "tested on", "accuracy", "F1", "precision", "recall", "majority class"):
        assert heading in table
    black = next(line for line in lines if "black" in line)
    assert "real photos" in black and "70.0% (39.7-89.2)" in black and "60.0%" in black  # Wilson 95 %, baseline
    procedural = next(line for line in lines if "procedural" in line and "%" in line)
    assert "60.0% (31.3-83.2)" in procedural and " - " in procedural  # undefined precision shows as "-"


def test_report_prints_the_summary(monkeypatch, tmp_path):
    report = write_report(tmp_path / "report")
    monkeypatch.setattr(Engine, "report", lambda self, data, out, real, overwrite, fewshot=None: report)
    res = invoke("report", tmp_path / "data", "--out", tmp_path / "report")
    assert res.exit_code == 0, res.output
    assert "70.0% (39.7-89.2)" in res.stdout and res.stdout.strip().endswith(f"report: {report}")


def _benchmark(variant: str, predictions: list[list[float]], paths: list[str], labels: list[int], majority: float):
    """A benchmark's results whose runs of ``variant`` predicted ``predictions``; every mean and std 0.5."""
    from deformsim.evaluate.results import Aggregate, ResultsFile

    real = {"accuracy": 0.5, "f1": 0.5, "precision": 0.5, "recall": 0.5, "auc": 0.5, "confusion": [[1, 1], [1, 1]]}
    runs = [{"variant": variant, "data_seed": 0, "composite_seed": 0, "train_seed": k, "model": f"m{k}", "real": real,
             "synthetic": {"accuracy": 0.5, "f1": 0.5}, "real_predictions": p} for k, p in enumerate(predictions)]
    results = ResultsFile.model_validate({
        "runs": runs, "seconds": 3.0, "majority_baseline": majority, "real_dir": "/photos", "real_images": len(paths),
        "real_paths": paths, "real_labels": labels, "settings": {"train": {"threshold": 0.5}}})
    spreads = {f"{k}_{s}": 0.5 for k in ("accuracy", "f1", "precision", "recall", "auc", "synthetic_accuracy",
                                         "synthetic_f1") for s in ("mean", "std")}
    results.variants = {variant: Aggregate(n_runs=len(runs), **spreads)}
    return results


def test_sim2real_prints_the_summary(monkeypatch, tmp_path):
    results = _benchmark("black", [[0.4] * 3] * 2, [f"/photos/{c}.jpg" for c in "abc"], [0, 1, 1], 0.62)
    monkeypatch.setattr(Engine, "sim2real", lambda self, *a, **kw: results)
    res = invoke("bench", "sim2real", "--real", tmp_path, "--out", tmp_path / "b")
    assert res.exit_code == 0, res.output
    black = next(line for line in res.stdout.splitlines() if "black" in line)
    assert "50.0 ± 50.0%" in black and "62.0%" in black
    # held-out renders at chance: said on the terminal, not only in the report
    assert "warning: variant black: mean held-out synthetic accuracy 0.50 is below 0.75" in res.stdout
    assert res.stdout.strip().endswith(f"report: {tmp_path / 'b' / 'report.html'}")


@pytest.fixture
def long_paths(monkeypatch, tmp_path):
    paths = [tmp_path / ("x" * 150) / f"photo_{i}.png" for i in range(2)]
    monkeypatch.setattr(Engine, "predict", lambda self, model, images, csv, threshold=None, adapt=None: Prediction(
        paths, {"p_deformed": [0.25, 0.75], "label": ["intact", "deformed"]}, ("P(deformed)", "label"), 0.5))
    return paths


def test_piped_predict_prints_whole_paths(long_paths, tmp_path):
    res = invoke("predict", tmp_path / "model", tmp_path)
    assert res.exit_code == 0, res.output
    assert res.stdout.splitlines() == [f"{long_paths[0]}\t0.2500\tintact", f"{long_paths[1]}\t0.7500\tdeformed"]
    assert res.stderr == "1 deformed of 2 images (threshold 0.5)\n"  # the data on stdout stays clean


def test_predict_on_a_terminal_right_aligns_the_numbers_and_counts(long_paths, tmp_path, monkeypatch):
    import io

    from rich.console import Console

    import deformsim.cli.learn

    screen = Console(file=io.StringIO(), force_terminal=True, width=400, color_system=None)
    monkeypatch.setattr(deformsim.cli.learn, "console", screen)
    res = invoke("predict", tmp_path / "model", tmp_path)
    assert res.exit_code == 0, res.output
    lines = screen.file.getvalue().splitlines()
    heading = next(line for line in lines if "P(deformed)" in line)
    row = next(line for line in lines if "0.2500" in line)
    assert row.index("0.2500") + len("0.2500") == heading.index("P(deformed)") + len("P(deformed)")
    assert lines[-1] == "1 deformed of 2 images (threshold 0.5)"


def test_sim2real_names_the_photos_most_often_wrong(monkeypatch, tmp_path):
    paths = [f"/photos/{c}/{i}[x].jpg" for c, i in (("intact", 0), ("intact", 1), ("deformed", 2))] + \
        [f"/photos/deformed/{i}.jpg" for i in range(3, 10)]
    labels = [0, 0, 1] + [1] * 7
    results = _benchmark("[red]v", [[0.9, 0.2 + 0.5 * k, 0.1] + [0.4] * 7 for k in range(2)], paths, labels, 0.8)
    monkeypatch.setattr(Engine, "sim2real", lambda self, *a, **kw: results)
    res = invoke("bench", "sim2real", "--real", tmp_path, "--out", tmp_path / "b")
    assert res.exit_code == 0, res.output
    line = next(line for line in res.stdout.splitlines() if line.startswith("most often wrong"))
    # 10 photos wrong: those wrong in both runs first, the confidently wrong (0.9, 0.1) before the 0.4s; the intact
    # photo wrong in one run last, among the 5 left unnamed
    assert line.startswith("most often wrong, [red]v: intact/0[x].jpg (2 of 2), deformed/2[x].jpg (2 of 2), "
                           "deformed/3.jpg (2 of 2), ")
    assert line.endswith(" and 5 more") and "intact/1[x].jpg" not in line
    assert res.stdout.strip().endswith(f"report: {tmp_path / 'b' / 'report.html'}")
