"""`deformsim train --target` and `predict` with the heads on dense labels (a tiny dense dataset, no Blender)."""

from __future__ import annotations

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
    (plain / "images").symlink_to(data / "images")
    res = invoke("train", plain, "--out", tmp_path / "m", "--target", "localise", "-c", config, *TRAIN)
    assert res.exit_code == 2 and "render.dense: true" in res.output and "region" in res.output
    assert len(res.output.strip().splitlines()) == 1
    res = invoke("train", data, "--out", tmp_path / "m", "--target", "depth", "-c", config, *TRAIN)
    assert res.exit_code == 2 and "depth" in res.output
