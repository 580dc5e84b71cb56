"""Prediction, ONNX export and the train/predict/export commands."""

from __future__ import annotations

import numpy as np
import onnx
import onnxruntime as ort
import pandas as pd
import pytest
import torch
import typer
from typer.testing import CliRunner

from deformsim.cli.learn import register
from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.data import load_image
from deformsim.learn.onnx import to_onnx
from deformsim.learn.predict import load
from deformsim.learn.train import fit

pytestmark = pytest.mark.torch


@pytest.fixture(scope="module")
def model_dir(blobs, tmp_path_factory):
    out = tmp_path_factory.mktemp("model")
    # briefly trained (low rate, one epoch) so its probabilities are not saturated at 0 or 1
    cfg = TrainConfig(weights="offline", image_size=64, epochs=1, lr=1e-4)
    fit(blobs.groupby("y").head(12), cfg, out, progress=False)
    return out


def test_onnx_agrees_with_pytorch(model_dir, blobs, tmp_path):
    paths = list(blobs.groupby("y").tail(4)["path"])
    expected = load(model_dir).predict_proba(paths)
    assert ((expected > 0.05) & (expected < 0.95)).sum() >= 4
    path = to_onnx(model_dir, tmp_path / "m.onnx")
    meta = {p.key: p.value for p in onnx.load(str(path)).metadata_props}
    assert meta["classes"] == "intact,deformed" and meta["image_size"] == "64"
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    x = torch.stack([load_image(p, 64) for p in paths]).numpy()
    got = session.run(["p_deformed"], {"image": x})[0]
    assert got.shape == (8,)
    np.testing.assert_allclose(got, expected, atol=1e-5)


def test_features_for_pca(model_dir, blobs):
    predictor = load(model_dir)
    paths = list(blobs["path"][:3])
    assert predictor.features(paths).shape == (3, 128)
    assert predictor.features(paths, "pooled").shape == (3, 512)
    with pytest.raises(UserError, match="conv5"):
        predictor.features(paths, "conv5")


def test_load_errors(tmp_path):
    with pytest.raises(UserError, match="no trained model"):
        load(tmp_path)
    (tmp_path / "model.pt").write_bytes(b"junk")
    with pytest.raises(UserError, match="not a deformsim model"):
        load(tmp_path)


def test_cli_train_predict_export(blobs, tmp_path):
    app = typer.Typer()
    register(app)
    run = CliRunner().invoke
    folder = tmp_path / "photos"
    for label in ("intact", "deformed"):
        (folder / label).mkdir(parents=True)
        for p in blobs[blobs["label"] == label]["path"][:6]:
            (folder / label / p.split("/")[-1]).write_bytes(open(p, "rb").read())
    cfg = tmp_path / "c.yaml"
    cfg.write_text("generate: {n: 8}\ntrain: {image_size: 64, weights: offline}\n")
    res = run(app, ["train", str(folder), "--out", str(tmp_path / "m"), "--epochs", "1", "--config", str(cfg),
                    "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "validation acc" in res.output and (tmp_path / "m" / "model.pt").is_file()
    res = run(app, ["predict", str(tmp_path / "m"), str(folder / "deformed"), "--csv", str(tmp_path / "p.csv")])
    assert res.exit_code == 0, res.output
    out = pd.read_csv(tmp_path / "p.csv")
    assert len(out) == 6 and out["p_deformed"].between(0, 1).all() and set(out["label"]) <= {"intact", "deformed"}
    res = run(app, ["export", str(tmp_path / "m"), "--onnx", str(tmp_path / "m.onnx")])
    assert res.exit_code == 0 and (tmp_path / "m.onnx").is_file()
    res = run(app, ["train", str(folder), "--out", str(tmp_path / "m"), "--epochs", "0", "--config", str(cfg)])
    assert res.exit_code == 2 and "train.epochs" in res.output
    res = run(app, ["train", str(folder), "--variant", "black", "--out", str(tmp_path / "m"), "--config", str(cfg)])
    assert res.exit_code == 2 and "manifest.parquet" in res.output
    res = run(app, ["predict", str(tmp_path / "m"), str(tmp_path / "nope.png")])
    assert res.exit_code == 2 and "nope.png" in res.output


def test_train_reads_generated_dataset_variant(blobs, tmp_path):
    from deformsim.dataset.tables import load_table

    rows = []
    for i, (p, y) in enumerate(zip(blobs["path"][::10], blobs["y"][::10])):
        iid = f"{i:06d}_c0"
        for kind in ("rgba", "black", "green"):
            (tmp_path / "images" / kind).mkdir(parents=True, exist_ok=True)
            (tmp_path / "images" / kind / f"{iid}.png").write_bytes(open(p, "rb").read())
        rows.append({"id": iid, "sample": i, "camera": 0, "label": ["intact", "deformed"][y], "y": y,
                     **{k: f"images/{k}/{iid}.png" for k in ("rgba", "black", "green")}})
    pd.DataFrame(rows).to_parquet(tmp_path / "manifest.parquet")
    table = load_table(tmp_path, None, "black")
    assert list(table["path"]) == [str(tmp_path / "images" / "black" / f"{r['id']}.png") for r in rows]
    with pytest.raises(UserError, match="variant 'nope'"):
        load_table(tmp_path, "nope", "black")


@pytest.mark.parametrize("option, width", [({"pool": "avgmax"}, 1024), ({"grey": True}, 512)])
def test_max_pooled_and_grey_models_train_reload_and_export(blobs, tmp_path, option, width):
    """Options inside the network (pooling both ways; grey images) hold after loading and in the ONNX file."""
    cfg = TrainConfig(weights="offline", image_size=64, epochs=2, batch_size=16, **option)
    result = fit(blobs, cfg, tmp_path / "m", progress=False)
    assert result.history[-1]["val_acc"] >= 0.75  # chance is 0.5
    predictor = load(tmp_path / "m")
    paths = list(blobs["path"][:4])
    assert predictor.features(paths, "pooled").shape == (4, width)  # avgmax: mean and maximum of 512 channels
    expected = predictor.predict_proba(paths)
    session = ort.InferenceSession(str(to_onnx(tmp_path / "m", tmp_path / "m.onnx")),
                                   providers=["CPUExecutionProvider"])
    got = session.run(["p_deformed"], {"image": torch.stack([load_image(p, 64) for p in paths]).numpy()})[0]
    np.testing.assert_allclose(got, expected, atol=1e-5)


def _non_square(paths: list[str], root) -> list[str]:
    """The images widened to 96 x 64 on a grey margin (where a test-time crop changes what the model sees)."""
    from PIL import Image

    root.mkdir()
    out = []
    for i, p in enumerate(paths):
        wide = Image.new("RGB", (96, 64), (120, 120, 120))
        wide.paste(Image.open(p).convert("RGB"), (8 + 3 * i % 24, 0))
        wide.save(root / f"{i}.png")
        out.append(str(root / f"{i}.png"))
    return out


@pytest.mark.parametrize("option", [{}, {"crop": "saliency", "tta_flip": True}, {"crop": "pad"}])
def test_predict_takes_the_onnx_export_with_the_models_probabilities(model_dir, blobs, tmp_path, option):
    """What an inspection station deploys: the .onnx file, read as the torch model reads its images."""
    from deformsim.api import Engine

    model = model_dir
    if option:
        model = tmp_path / "m"
        fit(blobs.groupby("y").head(12), TrainConfig(weights="offline", image_size=64, epochs=1, lr=1e-4, **option), model,
            progress=False)
    paths = _non_square(list(blobs.groupby("y").tail(5)["path"]), tmp_path / "wide")
    expected, labels = load(model).predict(paths)
    assert ((expected > 0.05) & (expected < 0.95)).sum() >= 4
    onnx_file = to_onnx(model, tmp_path / "m.onnx")
    got = Engine("quick").predict(onnx_file, paths, tmp_path / "p.csv")
    np.testing.assert_allclose(got.columns["p_deformed"], expected, atol=1e-5)
    assert list(got.columns["label"]) == labels
    assert list(pd.read_csv(tmp_path / "p.csv")["label"]) == labels


def test_predict_refuses_a_file_that_is_no_deformsim_export(tmp_path, blobs):
    from deformsim.api import Engine

    photo = blobs["path"][0]
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    with pytest.raises(UserError, match="junk.onnx is not an ONNX model"):
        Engine("quick").predict(tmp_path / "junk.onnx", [photo])
    with pytest.raises(UserError, match="no ONNX model at .*nope.onnx"):
        Engine("quick").predict(tmp_path / "nope.onnx", [photo])
    bare = onnx.helper.make_model(onnx.helper.make_graph(
        [onnx.helper.make_node("Identity", ["image"], ["p_deformed"])], "g",
        [onnx.helper.make_tensor_value_info("image", onnx.TensorProto.FLOAT, None)],
        [onnx.helper.make_tensor_value_info("p_deformed", onnx.TensorProto.FLOAT, None)]))
    onnx.save(bare, str(tmp_path / "bare.onnx"))
    with pytest.raises(UserError, match="bare.onnx is not a model deformsim exported .*image_size"):
        Engine("quick").predict(tmp_path / "bare.onnx", [photo])


BLOCKED = "import sys; sys.modules.update(dict.fromkeys(['torch', 'torchvision', 'bpy', 'OpenEXR', 'matplotlib', 'ray']))"


def _without_extras(*args: str):
    """The command line in a process where torch, Blender, matplotlib and Ray cannot be imported."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = Path(__file__).resolve().parents[2] / "src"
    code = f"{BLOCKED}; from deformsim.cli.app import app; app(sys.argv[1:], prog_name='deformsim')"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(src), "COLUMNS": "200"})


def test_without_the_extras_predict_reads_an_onnx_export_and_other_commands_name_the_extra(model_dir, blobs, tmp_path):
    onnx_file = to_onnx(model_dir, tmp_path / "m.onnx")
    photo = blobs["path"][0]
    proc = _without_extras("predict", str(onnx_file), photo)
    assert proc.returncode == 0, proc.stderr
    p = load(model_dir).predict_proba([photo])[0]
    assert proc.stdout.split() == [photo, f"{p:.4f}", "deformed" if p >= 0.5 else "intact"]
    proc = _without_extras("predict", str(model_dir), photo)
    assert proc.returncode == 1 and proc.stderr.strip().splitlines() == [
        "error: this command needs torch, which is not installed: pip install 'deformsim[train]'"]
    proc = _without_extras("generate", "--out", str(tmp_path / "data"), "--n", "8")
    assert proc.returncode == 1 and "rendering needs bpy, which is not installed: pip install 'deformsim[render]'" in proc.stderr
    assert not (tmp_path / "data").exists()


def _predict(*args):
    from deformsim.cli.app import app

    return CliRunner().invoke(app, ["predict", *map(str, args)])


def test_predict_threshold_json_csv_to_stdout_and_the_count(model_dir, blobs, tmp_path, monkeypatch):
    import json

    paths = list(blobs.groupby("y").head(3)["path"])
    p = load(model_dir).predict_proba(paths)
    cut = float(np.sort(p)[2] + np.sort(p)[3]) / 2  # three images below it, three at or above
    monkeypatch.chdir(tmp_path)
    res = _predict(model_dir, *paths, "--csv", "-", "--threshold", cut)
    assert res.exit_code == 0, res.output
    csv = pd.read_csv(__import__("io").StringIO(res.stdout))
    assert list(csv.columns) == ["path", "p_deformed", "label"] and len(csv) == 6
    assert list(csv["label"]) == ["deformed" if q >= cut else "intact" for q in p]
    assert not (tmp_path / "-").exists()  # stdout, not a file named -
    assert f"3 deformed of 6 images (threshold {cut:g})" in res.stderr
    res = _predict(model_dir, *paths, "--json")
    rows = [json.loads(line) for line in res.stdout.splitlines()]
    assert [r["path"] for r in rows] == [str(x) for x in paths] and rows[0]["p_deformed"] == pytest.approx(p[0])
    threshold = load(model_dir).cfg.threshold
    assert f"{int((p >= threshold).sum())} deformed of 6 images (threshold {threshold:g})" in res.stderr
    res = _predict(model_dir, *paths, "--threshold", "1.5")
    assert res.exit_code == 2 and res.output == "error: --threshold must lie in (0, 1), got 1.5\n"


def test_predict_on_a_run_or_report_folder_names_its_model(model_dir, blobs, tmp_path):
    import json
    import shutil

    from tests.report.made import experiment, metrics_file

    report = tmp_path / "run" / "report"
    shutil.copytree(model_dir, report / "models" / "procedural_split")
    y = [0, 0, 1, 1]
    (report / "metrics.json").write_text(json.dumps(metrics_file({  # procedural scores best: the headline test
        "black": {"n_images": 8, "split": experiment(y, [0.6, 0.4, 0.4, 0.6], "models/black_split/model.pt")},
        "procedural": {"n_images": 8, "split": experiment(y, [0.1, 0.2, 0.8, 0.9], "models/procedural_split/model.pt")}})))
    photo = blobs["path"][0]
    res = _predict(report, photo)
    assert res.exit_code == 2 and " ".join(res.output.split()) == (
        f"error: no trained model at {report} (a report folder: the model of its headline test is "
        f"{report / 'models' / 'procedural_split'})")
    shutil.copytree(model_dir, tmp_path / "run" / "model")
    res = _predict(tmp_path / "run", photo)
    assert res.exit_code == 2 and f"a run folder: its model is {tmp_path / 'run' / 'model'}" in res.output
