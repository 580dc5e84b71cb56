"""The report's dense-label heads, end to end on a tiny dense dataset drawn without Blender (2 epochs, 64 px)."""

import json
import re
import shutil

import pandas as pd
import pytest
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.dataset.layout import Layout
from deformsim.dataset.variants import variant_table
from deformsim.errors import UserError
from deformsim.evaluate.dense_experiments import plan
from deformsim.evaluate.metrics_file import read_metrics
from deformsim.learn.train_file import read_train
from tests.learn.conftest import learn_cache  # noqa: F401
from tests.learn.dense_blobs import make_dense_dataset

pytestmark = pytest.mark.torch

CFG = dict(weights="offline", epochs=2, image_size=64, batch_size=8, variants=["black"], seed=0)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = make_dense_dataset(tmp_path_factory.mktemp("dense") / "data", 6)
    m = pd.read_parquet(Layout(root).manifest).rename(columns={"family_crease": "family_cr<b>ease"})
    m.to_parquet(Layout(root).manifest, index=False)
    return root


@pytest.fixture(scope="module")
def real_dir(data, tmp_path_factory):
    real = tmp_path_factory.mktemp("real")
    m = pd.read_parquet(Layout(data).manifest)
    for _, r in m[m["camera"] == 0].head(4).iterrows():
        (real / r["label"]).mkdir(exist_ok=True)
        shutil.copy(data / r["black"], real / r["label"] / f"{r['id']}.png")
    return real


@pytest.fixture(scope="module")
def report(data, real_dir, tmp_path_factory):
    from deformsim.evaluate.experiments import run_experiments
    from deformsim.report.html import write_report

    out = tmp_path_factory.mktemp("rep")
    metrics = run_experiments(data, TrainConfig(**CFG), out, real_dir=real_dir, progress=False)
    return metrics, out, write_report(metrics, out).read_text()


def test_dense_heads_use_the_label_split(report):
    metrics, out, _ = report
    dense = metrics.dense
    assert read_metrics(out).dense == dense
    assert dense.variant == "black" and list(dense.heads) == ["severity", "family", "localise"]
    held_out = json.loads((out / "models" / "black_split" / "split.json").read_text())["test"]
    assert dense.n_test == len(held_out) == metrics.variants["black"].split.test.n
    for target, head in dense.heads.items():
        saved = read_train((out / head.model).parent)
        assert saved.config["target"] == target and saved.n_train + saved.n_val == dense.n_train
    sev = dense.heads["severity"].metrics
    assert sev.n == len(held_out) and sev.mae_mm >= 0 and (out / dense.heads["severity"].plot).is_file()
    assert set(dense.heads["family"].metrics.families) == {"dent", "cr<b>ease"}
    assert 0 <= dense.heads["localise"].metrics.iou <= 1
    assert dense.seconds < metrics.seconds


def test_real_photos_get_side_by_side_heatmaps(report, real_dir):
    metrics, out, _ = report
    maps = metrics.dense.heads["localise"].real_heatmaps
    assert len(maps) == 4
    for h in maps:
        with Image.open(out / h.image) as im, Image.open(h.path) as photo:
            assert im.size == (2 * photo.width + 6, photo.height)
        assert 0 <= h.region_fraction <= 1


def test_report_section_is_escaped_and_self_contained(report):
    metrics, _, html = report
    assert "Dense labels: severity, deformation families, localisation" in html
    assert "cr&lt;b&gt;ease" in html and "cr<b>ease" not in html
    assert f"{metrics.dense.heads['severity'].metrics.mae_mm:.2f} mm" in html
    srcs = re.findall(r"""src\s*=\s*["']?([^"'\s>]+)""", html)  # the page embeds every picture it shows
    links = re.findall(r"""href\s*=\s*["']?([^"'\s>]+)""", html)  # and links only to the full-size photos
    assert srcs and all(r.startswith("data:") for r in srcs) and all(r.startswith(("file:", "#")) for r in links)


def test_plan_picks_a_composite_only_with_its_own_maps(data, tmp_path):
    root = tmp_path / "data"
    shutil.copytree(data, root)
    vdir = Layout(root).variant_dir("bg")
    vdir.mkdir(parents=True)
    m = pd.read_parquet(Layout(root).manifest)
    v = pd.DataFrame({"id": m["id"], "image": m["black"]})
    v.to_parquet(vdir / "manifest.parquet", index=False)
    cfg = TrainConfig(**{**CFG, "variants": ["bg", "black"]})
    tables = {n: variant_table(root, n) for n in cfg.variants}
    assert plan(root, tables, cfg)[0] == "black"  # render-space maps would not match the composites
    v.assign(region=m["region"]).to_parquet(vdir / "manifest.parquet", index=False)
    name, table = plan(root, tables, cfg)
    assert name == "bg" and all(p.startswith(str(root)) for p in table["region"])
    (root / m["region"][0]).unlink()
    with pytest.raises(UserError, match="region mask"):
        plan(root, tables, cfg)
    assert plan(root, {"black": tables["black"].drop(columns=["region"])}, cfg) is None
