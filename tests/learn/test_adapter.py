"""Adapting a model to unlabelled photos: the labels of the folder are never read (the adapted model is the same to
the byte whatever the folders say), the adapter is what predict, evaluate and the benchmark apply, and bad folders
are refused in one line before any work."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.errors import UserError
from deformsim.evaluate.adaptation_file import AdaptBenchFile
from deformsim.evaluate.ceiling_file import CeilingFile
from deformsim.learn.adapt_file import AdaptFile
from deformsim.learn.adapt_stage import adapt_model
from deformsim.learn.adapter import Adapter, AdaptRecipe, em_prior, fit_adapter, fit_logistic, sigmoid
from deformsim.learn.predict import load
from deformsim.records import read_record
from tests.learn.blobs import make_blobs

pytestmark = pytest.mark.torch

def test_em_prior_recovers_the_share_of_a_calibrated_model():
    rng = np.random.default_rng(0)
    y = rng.random(4000) < 0.8  # 80 % deformed; the model was trained at 50 %
    score = rng.normal(np.where(y, 1.5, -1.5), 1.0)
    p = sigmoid(3.0 * score)  # calibrated at a balanced prior: log-likelihood ratio 3 * score
    assert abs(em_prior(p) - 0.8) < 0.03
    assert abs(em_prior(sigmoid(3.0 * rng.normal(np.where(rng.random(4000) < 0.3, 1.5, -1.5), 1.0))) - 0.3) < 0.03


def test_logistic_fit_separates_and_is_deterministic():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(200, 5))
    y = (x[:, 0] - x[:, 1] > 0).astype(float)
    w1, b1 = fit_logistic(x, y, np.ones(200), 1e-3)
    w2, b2 = fit_logistic(x, y, np.ones(200), 1e-3)
    assert np.array_equal(w1, w2) and b1 == b2
    assert ((x @ w1 + b1 > 0) == (y == 1)).mean() > 0.97
    assert w1[0] > 0 > w1[1]


def test_probe_corrects_scattered_errors_of_the_anchor():
    """Photos that look alike end up judged alike: a model wrong on 20 % of photos at random is corrected where
    the features cluster by class."""
    rng = np.random.default_rng(2)
    y = rng.random(300) < 0.5
    features = rng.normal(size=(300, 4)) + np.where(y, 2.0, -2.0)[:, None] * np.array([1, 0, 0, 0])
    wrong = rng.random(300) < 0.2
    p = np.where(y ^ wrong, 0.7, 0.3)
    adapter = fit_adapter(p, features, AdaptRecipe(method="probe", l2=0.1))
    before, after = ((p >= 0.5) == y).mean(), ((adapter.apply(p, features) >= 0.5) == y).mean()
    assert before < 0.8 and after > 0.93  # the Bayes rate of these features: 0.977


def test_labelled_photos_pull_the_probe_their_way():
    rng = np.random.default_rng(3)
    y = rng.random(200) < 0.5
    features = rng.normal(size=(200, 3)) + np.where(y, 1.5, -1.5)[:, None] * np.array([1, 0, 0])
    p = np.full(200, 0.5)  # an anchor that knows nothing
    labels = np.full(200, -1)
    labels[:20] = y[:20]
    adapter = fit_adapter(p, features, AdaptRecipe(method="probe"), labels)
    assert adapter.labelled == 20
    assert ((adapter.apply(p, features) >= 0.5) == y)[20:].mean() > 0.85


def test_saved_adapter_is_checked():
    good = fit_adapter(np.linspace(0.1, 0.9, 20), np.random.default_rng(0).normal(size=(20, 3))).to_dict()
    assert Adapter.from_dict(good).coef == good["coef"]
    for bad in ({**good, "scale": [0.0] * 3}, {**good, "coef": [float("nan")] * 3}, {**good, "method": "magic"},
                {**good, "coef": [1.0]}, {"method": "probe"}, [1, 2]):
        with pytest.raises(UserError, match="adapter"):
            Adapter.from_dict(bad, "m.pt")


def test_adapting_never_reads_labels(trained, photos, tmp_path):
    """The adapted model is the same to the byte when the photos' class folders are swapped, or flattened into one
    folder under other names."""
    root, _ = photos
    swapped = tmp_path / "swapped"
    shutil.copytree(root / "intact", swapped / "deformed")
    shutil.copytree(root / "deformed", swapped / "intact")
    flat = tmp_path / "flat"
    flat.mkdir()
    for k, path in enumerate(sorted(root.rglob("*.png"))):
        shutil.copy(path, flat / f"photo{k:03d}.png")
    outs = [adapt_model(trained, folder, tmp_path / f"m{k}", progress=False).model_path
            for k, folder in enumerate((root, swapped, flat))]
    states = [torch.load(o, weights_only=True) for o in outs]
    assert states[0]["adapter"] == states[1]["adapter"] == states[2]["adapter"]
    assert states[0]["adapted_unlabelled"] == states[2]["adapted_unlabelled"]
    a, b = (load(o, progress=False).predict_proba(sorted(flat.glob("*.png"))) for o in outs[::2])
    assert np.array_equal(a, b)


def test_adapted_model_applies_its_adapter_and_is_deterministic(trained, photos, tmp_path):
    root, table = photos
    first = adapt_model(trained, root, tmp_path / "a", progress=False)
    again = adapt_model(trained, root, tmp_path / "b", progress=False)
    assert first.photos == len(table)
    paths = list(table["path"])
    pa, pb = load(first.model_path, progress=False), load(again.model_path, progress=False)
    assert np.array_equal(pa.predict_proba(paths), pb.predict_proba(paths))
    synthetic, features = pa.outputs_and_features(paths, True)
    assert np.array_equal(synthetic, pa.synthetic_outputs(paths))
    assert np.allclose(pa.adapter.apply(synthetic, features), pa.predict_proba(paths))
    assert np.array_equal(synthetic, load(trained, progress=False).predict_proba(paths))


def test_every_method_adapts_and_records_what_it_judged(trained, photos, tmp_path):
    root, table = photos
    for method in ("probe", "prior", "probe+prior"):
        result = adapt_model(trained, root, tmp_path / method.replace("+", "-"), AdaptRecipe(method=method),
                             progress=False)
        adapted = load(result.model_path, progress=False)
        after = (adapted.predict_proba(list(table["path"])) >= adapted.cfg.threshold).mean()
        assert adapted.adapter.method == method and result.deformed_after == after


def test_bad_folders_are_one_line_before_any_work(trained, photos, tmp_path, blobs):
    root, _ = photos
    few = tmp_path / "few"
    few.mkdir()
    for path in sorted(root.rglob("*.png"))[:3]:
        shutil.copy(path, few / path.name)
    copies = tmp_path / "copies"
    copies.mkdir()
    one = sorted(root.rglob("*.png"))[0]
    for k in range(12):
        shutil.copy(one, copies / f"copy{k}.png")
    (tmp_path / "empty").mkdir()
    cases = {tmp_path / "missing": "not found", tmp_path / "empty": "holds no images", few: "3 distinct photo",
             copies: "1 distinct photo"}
    for folder, message in cases.items():
        with pytest.raises(UserError, match=message):
            adapt_model(trained, folder, tmp_path / "out", progress=False)
        assert not (tmp_path / "out").exists()
    with pytest.raises(UserError, match="adapt method"):
        AdaptRecipe(method="magic")


def test_adapting_on_renders_or_twice_is_refused(trained, photos, tmp_path):
    root, _ = photos
    dataset = tmp_path / "data"
    shutil.copytree(root, dataset / "images")
    (dataset / "manifest.parquet").write_bytes(b"")
    with pytest.raises(UserError, match="generated dataset"):
        adapt_model(trained, dataset / "images", tmp_path / "out", progress=False)
    adapted = adapt_model(trained, root, tmp_path / "once", progress=False).model_path
    with pytest.raises(UserError, match="adapted already"):
        adapt_model(adapted, root, tmp_path / "twice", progress=False)
    assert not (tmp_path / "twice").exists()


def test_cli_adapt_predict_adapt_and_benchmark(trained, photos, tmp_path):
    root, table = photos
    runner = CliRunner()
    done = runner.invoke(app, ["adapt", str(trained), "--photos", str(root), "--out", str(tmp_path / "m2"),
                               "--no-progress"])
    assert done.exit_code == 0, done.output
    assert "adapted on 12 photos" in done.output
    written = read_record(tmp_path / "m2" / "adapt.json", AdaptFile)
    assert (written.photos, written.labelled, written.recipe.method, written.folders.photos) == (12, 0, "probe", str(root))
    shown = runner.invoke(app, ["predict", str(trained), str(root), "--adapt"])
    assert shown.exit_code == 0, shown.output
    assert "an estimated" in shown.output
    bench = runner.invoke(app, ["bench", "adapt", str(trained), "--real", str(root), "--out", str(tmp_path / "b"),
                                "--folds", "2", "--no-progress"])
    assert bench.exit_code == 2 or bench.exit_code == 1, bench.output  # 12 photos: two folds of 8 need 16
    assert "needs 16" in bench.output
    more = tmp_path / "more"
    make_blobs(more, 10, seed=12)
    bench = runner.invoke(app, ["bench", "adapt", str(trained), "--real", str(more), "--out", str(tmp_path / "b"),
                                "--k", "1,3", "--draws", "2", "--no-progress"])
    assert bench.exit_code == 0, bench.output
    for row in ("unadapted", "probe transductive", "probe inductive", "prior inductive", "labelled probe",
                "the rest unlabelled"):
        assert row in bench.output
    kshot = read_record(tmp_path / "b" / "adapt.json", AdaptBenchFile).kshot
    assert [(r.k, r.runs) for r in kshot if r.curve == "unadapted"] == [(1, 2), (3, 2)]
    refused = runner.invoke(app, ["bench", "adapt", str(trained), "--real", str(more), "--out", str(tmp_path / "c"),
                                  "--k", "10"])
    assert refused.exit_code in (1, 2) and "k must leave one to score" in refused.output
    curves = runner.invoke(app, ["bench", "adapt", str(trained), "--real", str(more), "--out", str(tmp_path / "n"),
                                 "--n", "8", "--draws", "2", "--methods", "probe", "--no-progress"])
    assert curves.exit_code == 0, curves.output
    assert "n unlabelled photos" in curves.output
    rows = read_record(tmp_path / "n" / "adapt.json", AdaptBenchFile).unlabelled
    assert [(r.n, r.curve, r.runs) for r in rows] == [(8, "probe transductive", 2), (8, "probe inductive", 2)]
    refused = runner.invoke(app, ["bench", "adapt", str(trained), "--real", str(more), "--out", str(tmp_path / "c"),
                                  "--n", "8,12"])
    assert refused.exit_code in (1, 2) and "--n 12: adapting needs at least 8 photos, and 2 folds of 20 photos leave 10" \
        in refused.output


def test_the_onnx_export_holds_the_adapter(trained, photos, tmp_path):
    from deformsim.api import Engine
    from deformsim.learn.onnx import to_onnx

    root, table = photos
    for method in ("probe", "prior"):
        adapted = adapt_model(trained, root, tmp_path / method, AdaptRecipe(method=method), progress=False).model_path
        paths = list(table["path"])
        expected = load(adapted, progress=False).predict_proba(paths)
        assert not np.allclose(expected, load(trained, progress=False).predict_proba(paths), atol=1e-3)
        got = Engine("quick").predict(to_onnx(adapted, tmp_path / f"{method}.onnx"), paths)
        np.testing.assert_allclose(got.columns["p_deformed"], expected, atol=1e-5)


def test_bench_ceiling_cross_validates_frozen_features(blobs, tmp_path):
    """The round and jagged blobs are told apart by frozen ImageNet features with their labels; a bad backbone or
    size is one line."""
    root = Path(blobs["path"][0]).parents[1]
    runner = CliRunner()
    done = runner.invoke(app, ["bench", "ceiling", "--real", str(root), "--out", str(tmp_path / "c"), "--backbones",
                               "efficientnet_lite0", "--sizes", "64", "--folds", "4"])
    assert done.exit_code == 0, done.output
    (row,) = read_record(tmp_path / "c" / "ceiling.json", CeilingFile).rows
    assert row.backbone == "efficientnet_lite0" and row.size == 64 and row.accuracy > 0.8
    assert "s/photo" in done.output and 0 < row.seconds_per_photo < 60  # what the features of a photo cost
    for args, message in ((["--backbones", "resnet9"], "choose from"), (["--sizes", "16"], "must lie in"),
                          (["--sizes", "big"], "whole numbers")):
        bad = runner.invoke(app, ["bench", "ceiling", "--real", str(root), "--out", str(tmp_path / "d"), *args])
        assert bad.exit_code in (1, 2) and message in bad.output, bad.output
