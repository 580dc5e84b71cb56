"""The fuzz tests' valid inputs, made once without Blender: a dataset with a composited variant, a model trained
on it, an export of it, its cached features, and a PNG outside them whose bytes no output may hold."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest
from PIL import Image, PngImagePlugin
from typer.testing import CliRunner

from tests.fake_dense import make_dense_dataset
from tests.fuzz.harness import Child, tree_hash
from tests.fuzz.inputs import write_yaml

TOKEN = "deformsim-fuzz-secret-3f9a1c"
TINY_TRAIN = {"train": {"backbone": "mobilenet_v2", "weights": "none", "image_size": 32, "epochs": 1,
                        "batch_size": 8, "variants": ["black"]},
              "composite": {"workers": 1}}


@dataclass(frozen=True)
class Base:
    root: Path
    data: Path  # 8 images (4 samples x 2 cameras, dense maps) and the composited variant "procedural"
    model: Path  # trained on its black variant by TINY_TRAIN
    export: Path  # its black variant as an imagefolder export
    cache: Path  # DEFORMSIM_CACHE holding the model's features of every black image
    config: Path  # TINY_TRAIN as YAML
    secret: Path  # a valid PNG holding TOKEN, beside the dataset
    image: Path  # one black image of the dataset

    def copy(self, name: str, to: Path) -> Path:
        """A copy of the folder ``name`` (``data``, ``model``, ``export`` or ``cache``) at ``to``."""
        shutil.copytree(getattr(self, name), to, symlinks=True)
        return to

    def hashes(self) -> dict:
        return {p: tree_hash(p) for p in (self.data, self.model, self.export, self.secret)}


def invoke(*args) -> None:
    from deformsim.cli import app

    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output


def secret_png(path: Path) -> Path:
    info = PngImagePlugin.PngInfo()
    info.add_text("secret", TOKEN)
    Image.new("RGB", (48, 48), (200, 40, 30)).save(path, pnginfo=info)
    return path


@pytest.fixture(scope="session")
def base(tmp_path_factory) -> Base:
    root = tmp_path_factory.mktemp("fuzz-base")
    mp = pytest.MonkeyPatch()
    mp.setenv("DEFORMSIM_CACHE", str(root / "cache"))
    try:
        data = make_dense_dataset(root / "data", n_samples=4, cameras=2, size=48)
        config = write_yaml(root / "tiny.yaml", TINY_TRAIN)
        invoke("composite", data, "--workers", "1", "--no-progress")
        invoke("train", data, "--variant", "black", "--out", root / "model", "-c", config, "--no-progress")
        invoke("export-data", data, root / "export", "--format", "imagefolder", "--variant", "black", "--no-progress")
        image = sorted((data / "images" / "black").glob("*.png"))[0]
        invoke("predict", root / "model", data / "images" / "black")
    finally:
        mp.undo()
    return Base(root, data, root / "model", root / "export", root / "cache", config, secret_png(root / "SECRET.png"),
                image)


@pytest.fixture
def unchanged(base):
    """Fails a test whose commands changed the base inputs (each case works on copies or only reads them)."""
    before = base.hashes()
    yield base
    assert base.hashes() == before, "a fuzz case changed the base dataset, model, export or secret"


@pytest.fixture(scope="session")
def child(tmp_path_factory):
    """The process every fuzz case runs in (see :class:`tests.fuzz.harness.Child`)."""
    runner = Child(tmp_path_factory.mktemp("fuzz-child"))
    yield runner
    runner.close()
