"""`deformsim show`: contact sheets of a composited or render variant and of the dense maps beside each image."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.contact_sheet import COLORS
from deformsim.dataset.layout import DENSE_KINDS
from tests.fake_dense import PART_RGB, make_dense_dataset


@pytest.fixture
def data(tmp_path):
    root = make_dense_dataset(tmp_path / "data")
    composite(root, CompositeConfig(matte="alpha", workers=1), "bg", seed=4, progress=False)
    return root


def show(*args: str):
    return CliRunner().invoke(app, ["show", *map(str, args)])


def test_a_composited_variant_sheet_shows_its_images_with_their_labels(data, tmp_path):
    out = tmp_path / "sheet.png"
    run = show(data, "--variant", "bg", "--out", out, "--count", "4")
    assert run.exit_code == 0, run.output
    sheet = np.asarray(Image.open(out).convert("RGB"))
    assert sheet.shape[:2] == (160 + 20, 4 * 160)  # one row of four tiles over their caption bars
    bars = {tuple(int(v) for v in sheet[179, 160 * k + 150]) for k in range(4)}
    assert bars == set(COLORS.values())  # both labels, each in its colour
    tiles = sheet[:160].reshape(160, 4, 160, 3)
    red = (np.abs(tiles.astype(int) - PART_RGB).sum(-1) < 60).mean(axis=(0, 2))
    assert (red > 0.02).sum() >= 3  # the part is on the composited backgrounds (one sample has a view without it)


def test_dense_sheet_puts_each_map_beside_its_image(data, tmp_path):
    out = tmp_path / "dense.png"
    run = show(data, "--variant", "black", "--dense", "--out", out, "--count", "4")
    assert run.exit_code == 0, run.output
    sheet = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert sheet.shape[:2] == (4 * 180, (1 + len(DENSE_KINDS)) * 160)
    seen = 0
    for row in range(4):
        image, *maps = [sheet[row * 180:row * 180 + 160, c * 160:(c + 1) * 160] for c in range(1 + len(DENSE_KINDS))]
        part = np.abs(image - PART_RGB).sum(-1) < 60
        mask = dict(zip(DENSE_KINDS, maps))["mask"].mean(-1) > 128
        assert (part == mask).mean() > 0.97  # the mask covers the part in the image beside it
        seen += part.any()
    assert seen >= 3


def test_show_refuses_an_unknown_variant_and_dense_maps_a_dataset_lacks(tmp_path):
    plain = make_dense_dataset(tmp_path / "plain", dense=False)
    run = show(plain, "--variant", "black", "--dense", "--out", tmp_path / "x.png")
    assert run.exit_code == 2 and "no dense maps" in run.output and not (tmp_path / "x.png").exists()
    run = show(plain, "--variant", "nope", "--out", tmp_path / "x.png")
    assert run.exit_code == 2 and "nope" in run.output
