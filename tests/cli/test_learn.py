"""`deformsim train --target` and `predict` with the heads on dense labels (a tiny dense dataset, no Blender)."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest
from typer.testing import CliRunner

from deformsim.cli.app import app
from tests.learn.dense_blobs import FAMILIES, make_dense_dataset

pytestmark = pytest.mark.torch

TRAIN = ["--epochs", "2", "--weights", "offline", "--no-progress"]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return make_dense_dataset(tmp_path_factory.mktemp("dense") / "data", 4, size=64)


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "cfg.yaml"
    path.write_text("train: {image_size: 64, batch_size: 8}\n")
    return path


def test_train_and_predict_a_family_model(data, config, tmp_path):
    res = invoke("train", data, "--out", tmp_path / "m", "--variant", "black", "--target", "family", "-c", config, *TRAIN)
    assert res.exit_code == 0, res.output
    assert "validation f1" in res.output
    images = sorted((data / "images" / "black").glob("*.png"))[:3]
    res = invoke("predict", tmp_path / "m", *images, "--csv", tmp_path / "p.csv")
    assert res.exit_code == 0, res.output
    out = pd.read_csv(tmp_path / "p.csv")
    assert list(out.columns) == ["path", *(f"p_{f}" for f in FAMILIES)] and len(out) == 3
    assert out[[f"p_{f}" for f in FAMILIES]].stack().between(0, 1).all()


def test_localise_needs_region_masks(data, config, tmp_path):
    pd.read_parquet(data / "manifest.parquet").drop(columns=["region"]).to_parquet(tmp_path / "manifest.parquet")
    plain = tmp_path / "plain"
    plain.mkdir()
    (tmp_path / "manifest.parquet").rename(plain / "manifest.parquet")
    shutil.copytree(data / "images", plain / "images")  # a symlink out of the dataset would be refused
    res = invoke("train", plain, "--out", tmp_path / "m", "--target", "localise", "-c", config, *TRAIN)
    assert res.exit_code == 2 and "render.dense: true" in res.output and "region" in res.output
    assert len(res.output.strip().splitlines()) == 1
    res = invoke("train", data, "--out", tmp_path / "m", "--target", "depth", "-c", config, *TRAIN)
    assert res.exit_code == 2 and "depth" in res.output


def _one_error_line(res, code, *words):
    """Exit ``code`` with one error line (after any line saying what the command does) holding ``words``."""
    lines = res.output.strip().splitlines()
    errors = [line for line in lines if line.startswith("error:")]
    assert res.exit_code == code and errors == lines[-1:] and "Traceback" not in res.output, res.output
    assert all(w in errors[0] for w in words), errors[0]


def test_a_truncated_variant_manifest_is_one_line_for_train_and_evaluate(config, tmp_path):
    from deformsim.composite.stage import composite
    from deformsim.config import CompositeConfig
    from tests.fake_dense import make_dense_dataset as make_rendered

    data = make_rendered(tmp_path / "data", dense=False)
    composite(data, CompositeConfig(workers=1), "comp", progress=False)
    manifest = data / "variants" / "comp" / "manifest.parquet"
    manifest.write_bytes(manifest.read_bytes()[:64])
    _one_error_line(invoke("train", data, "--out", tmp_path / "m", "--variant", "comp", "-c", config, *TRAIN), 2,
                    str(manifest), "unreadable")
    assert invoke("train", data, "--out", tmp_path / "m", "--variant", "black", "-c", config, *TRAIN).exit_code == 0
    _one_error_line(invoke("evaluate", tmp_path / "m", "--data", data, "--variant", "comp"), 2, str(manifest))


def test_training_on_one_class_is_refused_in_one_line(data, config, tmp_path):
    one = tmp_path / "one"
    shutil.copytree(data, one, ignore=shutil.ignore_patterns("variants"))
    manifest = pd.read_parquet(one / "manifest.parquet")
    manifest[manifest["y"] == 1].to_parquet(one / "manifest.parquet", index=False)
    res = invoke("train", one, "--out", tmp_path / "m", "--variant", "black", "-c", config, *TRAIN)
    _one_error_line(res, 2, f"variant 'black' of {one}", "0 intact and 8 deformed", "both classes")
    assert not (tmp_path / "m").exists()


def test_training_onto_a_full_disk_is_one_line(data, config, tmp_path, monkeypatch):
    """torch.save on a full disk fails half-written with torch's own RuntimeError (as on a full 1 MiB tmpfs): one
    line naming the file, exit 1, and no model left behind."""
    import torch

    save = torch.save

    def full(obj, f, *args, **kwargs):
        if not str(getattr(f, "name", "")).startswith(str(tmp_path)):
            return save(obj, f, *args, **kwargs)  # the weights cache
        f.write(b"PK" * 256)
        raise RuntimeError("[enforce fail at inline_container.cc:672] . unexpected pos 576 vs 534")

    monkeypatch.setattr(torch, "save", full)
    res = invoke("train", data, "--out", tmp_path / "m", "--variant", "black", "-c", config, *TRAIN)
    _one_error_line(res, 1, "model.pt", "disk full")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cfg.yaml"]  # no model, no staging folder left
