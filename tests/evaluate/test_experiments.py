"""End to end on a tiny rendered dataset: Table II experiments, the report, and the CLI (1 epoch, 64 px)."""

import json
import re
import shutil

import pandas as pd
import pytest
from PIL import Image, ImageOps
from typer.testing import CliRunner

from deformsim.config import TrainConfig
from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout, image_id
from deformsim.evaluate.experiments import review_order
from deformsim.evaluate.metrics_file import Counts, Evaluation, Prediction, read_metrics
from deformsim.records import read_record

pytestmark = [pytest.mark.torch, pytest.mark.blender]

CFG = dict(weights="none", epochs=1, image_size=64, batch_size=8, variants=["black", "backgrounds"], seed=0)


@pytest.fixture(scope="module")
def four_samples(tiny_dataset, tmp_path_factory):
    """The tiny dataset (2 scene states) plus a mirrored copy of each: 2 intact + 2 deformed samples of 4 views,
    enough for a stratified split by sample."""
    src = Layout(tiny_dataset)
    dst = Layout(tmp_path_factory.mktemp("four") / "data")
    manifest = pd.read_parquet(src.manifest)
    n = manifest["sample"].max() + 1
    rows = []
    for copy in (0, 1):
        for _, r in manifest.iterrows():
            r = r.copy()
            r["sample"] += copy * n
            r["id"] = image_id(r["sample"], r["camera"])
            for kind in [k for k in (*RENDER_KINDS, *DENSE_KINDS) if k in manifest.columns]:
                out = dst.image(kind, r["id"])
                out.parent.mkdir(parents=True, exist_ok=True)
                with Image.open(src.root / r[kind]) as im:
                    (ImageOps.mirror(im) if copy else im.copy()).save(out)
                r[kind] = dst.rel(out)
            rows.append(r)
    pd.DataFrame(rows).to_parquet(dst.manifest, index=False)
    return dst.root


@pytest.fixture(scope="module")
def real_dir(four_samples, tmp_path_factory):
    """Stand-in 'real' photos: the green-background renders, sorted into intact/ and deformed/."""
    real = tmp_path_factory.mktemp("real")
    m = pd.read_parquet(Layout(four_samples).manifest)
    for _, r in m[m["sample"] < 2].iterrows():
        (real / r["label"]).mkdir(exist_ok=True)
        shutil.copy(four_samples / r["green"], real / r["label"] / f"{r['id']}.png")
    return real


@pytest.fixture(scope="module")
def experiments(four_samples, real_dir, tmp_path_factory):
    from deformsim.evaluate.experiments import run_experiments

    out = tmp_path_factory.mktemp("exp")
    return run_experiments(four_samples, TrainConfig(**CFG), out, real_dir=real_dir, progress=False), out


def test_table2_experiments(experiments, four_samples):
    metrics, out = experiments
    assert read_metrics(out) == metrics
    assert metrics.missing_variants == ["backgrounds"]
    black = metrics.variants["black"]
    split, real = black.split, black.real
    # split: one whole intact and one whole deformed scene held out, all 4 views each
    assert split.test == Counts(n=8, n_deformed=4, n_samples=2)
    assert split.train == Counts(n=8, n_deformed=4, n_samples=2)
    saved = json.loads((out / "models" / "black_split" / "split.json").read_text())
    sample = lambda ids: {i.split("_")[0] for i in ids}  # noqa: E731
    assert sample(saved["train"]).isdisjoint(sample(saved["test"]))
    # sim-to-real: trained on all 16 synthetic images, tested on the 8 'real' ones
    assert real.train.n == 16 and real.test.n == 8
    assert (out / real.model).exists() and (out / split.model).exists()
    for part in (split, real):
        m = part.metrics
        assert sum(map(sum, m.confusion.matrix)) == m.n == len(part.predictions)
        assert all(0 <= p.prob <= 1 for p in part.predictions)
        right = sum((p.prob >= 0.5) == bool(p.y) for p in part.predictions)
        assert m.accuracy == pytest.approx(right / m.n)
        assert [h.epoch for h in part.history] == [1] and "none" in part.weights
    assert black.summary["real"].accuracy == real.metrics.accuracy
    # Grad-CAM of the real-test model: every photo (8 < GRADCAM_MAX), misclassified first, one PNG each
    assert split.gradcam is None and "gradcam" not in split.model_fields_set
    order = [real.predictions[i] for i in review_order(real.predictions, 0.5)]
    assert [Prediction(path=c.path, y=c.y, prob=c.prob) for c in real.gradcam] == order
    for c in real.gradcam:
        assert c.image.startswith("gradcam/black/")
        with Image.open(out / c.image) as im, Image.open(c.path) as photo:
            assert im.format == "PNG" and im.size == photo.size  # 64 px photos: not enlarged
    for name in [metrics.plots.pca_pixels, *metrics.plots.pca_features.values()]:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(metrics.plots.pca_features) == ["black"]


def test_report_from_experiments(experiments):
    from deformsim.report.html import write_report

    metrics, out = experiments
    html = write_report(metrics, out).read_text()
    acc = metrics.variants["black"].real.metrics.accuracy
    assert f"{100 * acc:.1f}%" in html
    assert html.count("data:image/png;base64,") >= 4  # pixel PCA, feature PCA, training curves, reliability
    assert "Calibration on the real photographs" in html
    assert html.count('class="thumb cam ') == len(metrics.variants["black"].real.gradcam)
    srcs = re.findall(r"""src\s*=\s*["']?([^"'\s>]+)""", html)  # the page embeds every picture it shows
    links = re.findall(r"""href\s*=\s*["']?([^"'\s>]+)""", html)  # and links only to the full-size photos
    assert srcs and all(r.startswith("data:") for r in srcs) and all(r.startswith(("file:", "#")) for r in links)


def test_cli_evaluate_and_report(experiments, four_samples, real_dir, tmp_path):
    import typer

    from deformsim.cli import evaluate

    app = typer.Typer()
    evaluate.register(app)
    metrics, out = experiments
    runner = CliRunner()
    res = runner.invoke(app, ["evaluate", str(out / "models" / "black_split"), "--data", str(four_samples),
                              "--variant", "black", "--out", str(tmp_path / "m.json")])
    assert res.exit_code == 0, res.output
    saved = read_record(tmp_path / "m.json", Evaluation)
    assert saved.held_out and saved.n_images == 8
    assert saved.metrics == metrics.variants["black"].split.metrics
    res = runner.invoke(app, ["evaluate", str(out / "models" / "black_full"), "--real", str(real_dir)])
    assert res.exit_code == 0 and f"{100 * metrics.variants['black'].real.metrics.accuracy:.1f}%" in res.output

    res = runner.invoke(app, ["evaluate", str(out / "models" / "black_full"), "--data", str(four_samples)])
    assert res.exit_code == 2 and "which variant" in res.output
    res = runner.invoke(app, ["report", str(four_samples), "--real", str(tmp_path / "nope")])
    assert res.exit_code == 2 and "nope" in res.output

    cfg = tmp_path / "cfg.yaml"
    cfg.write_text("train: {image_size: 64, batch_size: 8}\n")
    res = runner.invoke(app, ["report", str(four_samples), "--out", str(tmp_path / "rep"), "--config", str(cfg),
                              "--variants", "black", "--epochs", "1", "--weights", "none", "--no-progress"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "rep" / "report.html").is_file() and "report.html" in res.output
    rep = read_metrics(tmp_path / "rep")
    assert list(rep.variants) == ["black"] and rep.variants["black"].real is None
    assert rep.settings["epochs"] == 1


def test_evaluate_on_renders_leaves_out_what_the_model_was_trained_not_to_see(dent_out_of_view, tmp_path):
    """train.min_region: the synthetic test, like training, holds no deformed image whose damage does not show."""
    from deformsim.evaluate.experiments import evaluate_model
    from deformsim.learn.stage import train_model

    data, hidden = dent_out_of_view
    cfg = TrainConfig(weights="offline", image_size=32, epochs=1, batch_size=4, min_region=0.02)
    model = train_model(data, cfg, tmp_path / "m", variant="black", progress=False).model_path
    scored = evaluate_model(model, data, "black")
    assert scored.n_images == 7 and all(hidden not in p.path for p in scored.predictions)
