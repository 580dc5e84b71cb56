"""Composite with rendered surface scenes (render.surface): a drawn share of the images shows the scene whole."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest

from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.layout import Layout
from deformsim.errors import UserError
from tests.composite.conftest import with_images


def _on_board(rgba):
    h, w = rgba.shape[:2]
    board = ((np.indices((h, w)).sum(0) // 4) % 2 * 120 + 60).astype(np.float32)[..., None]
    a = rgba[..., 3:4] / 255.0
    return np.rint(rgba[..., :3] * a + board * (1 - a)).astype(np.uint8)


def _with_surfaces(src, dst):
    """A copy of the dataset at ``src`` with a made-up surface scene per image: the part over a checkerboard."""
    return with_images(src, dst, "surface", _on_board)


def test_surface_share_shows_the_scene_whole_and_leaves_the_rest(dataset, tmp_path):
    scenes = _with_surfaces(dataset, tmp_path / "scenes")
    plain = composite(scenes, CompositeConfig(workers=1), "p", seed=2, progress=False).folder
    mixed = composite(scenes, CompositeConfig(workers=1, surface=0.5), "m", seed=2, progress=False).folder
    m = pd.read_parquet(mixed / "manifest.parquet")
    shown = m["background"] == "surface"
    assert 0 < shown.sum() < len(m)  # a share, drawn per image
    assert (m.loc[shown, "matte"] == "none").all()
    for row in m.itertuples():
        out = cv2.imread(str(mixed / "images" / f"{row.id}.png"))
        if row.background == "surface":  # no framing, no flip: the scene itself
            assert np.array_equal(out, cv2.imread(str(Layout(scenes).image("surface", row.id))))
        else:  # the rest is exactly the composite without surfaces
            assert np.array_equal(out, cv2.imread(str(plain / "images" / f"{row.id}.png")))


def test_surface_scenes_are_framed_around_the_part(dataset, tmp_path):
    scenes = _with_surfaces(dataset, tmp_path / "scenes")
    v = composite(scenes, CompositeConfig(workers=1, surface=1.0, object_fill=(0.8, 0.8), fill_offset=0.0),
                  "f", seed=0, progress=False).folder
    m = pd.read_parquet(v / "manifest.parquet")
    assert (m["background"] == "surface").all() and (m["frame_fill"] == 0.8).all()
    for row in m.itertuples():
        mask = cv2.imread(str(v / "mask" / f"{row.id}.png"), cv2.IMREAD_UNCHANGED)
        ys, xs = np.nonzero(mask > 127)
        side = max(xs.max() - xs.min() + 1, ys.max() - ys.min() + 1) / mask.shape[0]
        assert side == pytest.approx(0.8, abs=0.06) or row.frame_side == min(mask.shape)  # clipped to the render


def test_surface_share_needs_surface_scenes(dataset):
    with pytest.raises(UserError, match="render.surface"):
        composite(dataset, CompositeConfig(workers=1, surface=0.3), "x", seed=0, progress=False)
    assert not (dataset / "variants" / "x").exists()


def test_a_dataset_whose_part_images_are_not_in_colour_composites_its_surface_scenes_only(dataset, tmp_path):
    """render.surface.part_colour: false leaves the part's own images crude: composite refuses to show them."""
    scenes = _with_surfaces(dataset, tmp_path / "scenes")
    config = Layout(scenes).config
    config.write_text("render:\n  surface:\n    kinds: [wood]\n    part_colour: false\n")
    for share in (0.0, 0.5):
        with pytest.raises(UserError, match=rf"^dataset {scenes} was rendered with render.surface.part_colour: false, "
                                            rf"so only its surface scenes are training images: set composite.surface "
                                            rf"to 1, not {share:g}$"):
            composite(scenes, CompositeConfig(workers=1, surface=share), "x", seed=0, progress=False)
    assert not (scenes / "variants" / "x").exists()
    made = composite(scenes, CompositeConfig(workers=1, surface=1.0), "s", seed=0, progress=False)
    assert made.surfaces == made.images
