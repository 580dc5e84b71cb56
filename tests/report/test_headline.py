"""The model a report or a run is meant to be used with, and the variants a report trains."""

from __future__ import annotations

import json

from deformsim.config import TrainConfig
from deformsim.pipeline import _report_split
from deformsim.report.headline import headline_model, link_model
from deformsim.report.stage import present_variants
from tests.report.made import experiment, metrics_file


def report(folder, accuracies: dict[str, dict[str, float]]):
    """A report folder whose variants' tests scored ``accuracies`` ({variant: {part: accuracy}}), a model each."""
    variants = {}
    for v, parts in accuracies.items():
        variants[v] = {}
        for part, acc in parts.items():
            model = folder / "models" / f"{v}_{part}"
            model.mkdir(parents=True)
            (model / "model.pt").write_bytes(f"{v} {part}".encode())
            test = experiment([0, 1], [0.2, 0.8], f"models/{v}_{part}/model.pt", train_seconds=2.5)
            test["metrics"]["accuracy"] = acc
            variants[v][part] = test
    (folder / "metrics.json").write_text(json.dumps(metrics_file({v: {"n_images": 2, **e} for v, e in variants.items()})))
    return folder


def test_the_headline_model_is_the_best_real_test_else_the_best_held_out_one(tmp_path):
    both = report(tmp_path / "a", {"black": {"split": 0.99, "real": 0.6}, "procedural": {"split": 0.9, "real": 0.8}})
    assert headline_model(both) == both / "models" / "procedural_real"
    synthetic = report(tmp_path / "b", {"black": {"split": 0.99}, "procedural": {"split": 0.9}})
    assert headline_model(synthetic) == synthetic / "models" / "black_split"
    assert headline_model(tmp_path / "nothing") is None


def test_the_run_model_is_linked_not_copied_and_replaced_whole(tmp_path):
    folder = report(tmp_path / "report", {"black": {"split": 0.9}})
    out = link_model(headline_model(folder), tmp_path / "model")
    assert (out / "model.pt").read_bytes() == b"black split"
    assert (out / "model.pt").stat().st_ino == (folder / "models" / "black_split" / "model.pt").stat().st_ino
    (out / "stale.txt").write_text("from an older run")
    link_model(headline_model(folder), out)
    assert sorted(p.name for p in out.iterdir()) == ["model.pt"]


def test_the_report_stage_time_is_split_into_training_and_the_rest(tmp_path):
    folder = report(tmp_path / "r", {"black": {"split": 0.9, "real": 0.7}})
    assert _report_split(12.0, folder / "metrics.json") == {"report: training": 5.0,
                                                          "report: testing, plots and the page": 7.0}
    metrics = json.loads((folder / "metrics.json").read_text())
    (folder / "metrics.json").write_text(json.dumps({**metrics, "dense": {"variant": "black", "seconds": 4.0}}))
    assert _report_split(12.0, folder / "metrics.json") == {
        "report: training": 5.0, "report: dense-label heads": 4.0, "report: testing, plots and the page": 3.0}
    assert _report_split(12.0, tmp_path / "missing.json") == {"report": 12.0}


def dataset(folder, composited):
    for name in composited:
        (folder / "variants" / name).mkdir(parents=True)
        (folder / "variants" / name / "manifest.parquet").write_bytes(b"")
    return folder


def test_a_report_trains_the_composites_made_in_place_of_missing_variants(tmp_path):
    data = dataset(tmp_path / "data", ["procedural"])
    cfg, note = present_variants(data, TrainConfig(variants=["black", "backgrounds"]))
    assert cfg.variants == ["black", "procedural"]
    assert note == f"variant backgrounds not in {data}: training on black, procedural instead (--variants picks)"


def test_a_report_names_the_composites_it_leaves_out(tmp_path):
    data = dataset(tmp_path / "data", ["backgrounds", "procedural"])
    cfg = TrainConfig(variants=["black", "backgrounds"])
    assert present_variants(data, cfg) == (cfg, f"variant procedural of {data} not trained (train.variants: black, "
                                                "backgrounds): add it with --variants black,backgrounds,procedural")
    assert present_variants(dataset(tmp_path / "d2", ["backgrounds"]), cfg) == (cfg, None)


def test_the_report_command_says_which_variants_it_trains(tmp_path, monkeypatch):
    """After `composite` (procedural), `report` trained black alone and said nothing of procedural."""
    from typer.testing import CliRunner

    from deformsim.cli.app import app
    from deformsim.errors import UserError

    data = dataset(tmp_path / "data", ["procedural"])
    (data / "manifest.parquet").write_bytes(b"")  # read by content only: the dataset's checks are the test's
    monkeypatch.setattr("deformsim.dataset.manifest.read_manifest", lambda root: None)
    trained = []

    def experiments(data_root, cfg, out, **kw):
        trained.append(cfg.variants)
        raise UserError("stopped by the test")

    monkeypatch.setattr("deformsim.evaluate.experiments.run_experiments", experiments)
    res = CliRunner().invoke(app, ["report", str(data), "--out", str(tmp_path / "report")])
    assert trained == [["black", "procedural"]], res.output
    assert "training on black, procedural instead (--variants picks)" in res.stderr
