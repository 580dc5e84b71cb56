"""``deformsim export-data``: the command exports each format, shows what it did, and refuses bad input in one line."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from deformsim.cli.app import app
from tests.fake_dense import make_dense_dataset


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return make_dense_dataset(tmp_path_factory.mktemp("cli") / "data")


def invoke(*args):
    return CliRunner().invoke(app, ["export-data", *map(str, args)])


@pytest.mark.parametrize("fmt, marker", [("imagefolder", "labels.csv"), ("coco", "annotations/instances.json"),
                                         ("anomalib", "folder.yaml")])
def test_each_format(data, tmp_path, fmt, marker):
    res = invoke(data, tmp_path / "out", "--format", fmt, "--no-progress")
    assert res.exit_code == 0, res.output
    assert "8 images of variant black" in res.output and "hard-linked" in res.output
    assert (tmp_path / "out" / marker).is_file() and (tmp_path / "out" / "README.txt").is_file()
    assert json.loads((tmp_path / "out" / "export.json").read_text())["variant"] == "black"


def test_variant_and_overwrite(data, tmp_path):
    out = tmp_path / "out"
    assert invoke(data, out, "-f", "imagefolder", "--variant", "green", "--no-progress").exit_code == 0
    res = invoke(data, out, "-f", "coco", "--no-progress")
    assert res.exit_code == 2 and res.output.strip().startswith("error:") and len(res.output.strip().splitlines()) == 1
    assert "--overwrite" in res.output and (out / "intact").is_dir()
    res = invoke(data, out, "-f", "coco", "--overwrite", "--no-progress")
    assert res.exit_code == 0, res.output
    assert not (out / "intact").exists() and (out / "annotations" / "instances.json").is_file()


@pytest.mark.parametrize("args, words", [
    (["--format", "yolo"], "unknown export format 'yolo'"),
    (["--format", "coco", "--variant", "nope"], "variant 'nope' not found"),
])
def test_bad_input(data, tmp_path, args, words):
    res = invoke(data, tmp_path / "out", *args)
    assert res.exit_code == 2 and words in res.output and "Traceback" not in res.output
    assert not (tmp_path / "out").exists()


def test_not_a_dataset(tmp_path):
    (tmp_path / "data").mkdir()
    res = invoke(tmp_path / "data", tmp_path / "out", "--format", "coco")
    assert res.exit_code == 2 and "not a generated dataset" in res.output


def test_copy_makes_an_independent_export(data, tmp_path):
    res = invoke(data, tmp_path / "out", "-f", "imagefolder", "--copy", "--no-progress")
    assert res.exit_code == 0, res.output
    assert "(8 copied)" in res.output and "hard-linked" not in res.output
    assert all(p.stat().st_nlink == 1 for p in (tmp_path / "out").rglob("*.png"))
    assert "Every file here is a copy" in (tmp_path / "out" / "README.txt").read_text()
