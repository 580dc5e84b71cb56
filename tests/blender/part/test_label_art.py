"""The label designer of render.appearance (pure numpy + PIL, no Blender)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from deformsim.blender.part.can_label import make_label
from deformsim.blender.part.label_art import make_artwork
from deformsim.sampling import AppearanceParams, CanDesign

DESIGN = CanDesign(hue=0.6, saturation=0.8, value=0.6, accent_hue=0.1, bands=2, band_seed=3, word="NOVA")


def look(style: str, seed: int = 5, metallic: bool = False, photo: str = "") -> AppearanceParams:
    return AppearanceParams(style=style, seed=seed, metallic=metallic, photo=photo, crop=(0.3, 0.6, 1.5), gloss=0.4,
                            roughness=0.3)


def test_designs_are_deterministic_and_differ_by_seed():
    a, b = make_artwork(DESIGN, look("designer", 5), 128, 64), make_artwork(DESIGN, look("designer", 5), 128, 64)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    c = make_artwork(DESIGN, look("designer", 6), 128, 64)
    assert not np.array_equal(a[0], c[0])
    assert a[0].shape == (64, 128, 4) and a[1].shape == (64, 128) and a[0].dtype == np.float32


def test_metal_shows_where_the_style_says():
    plain_rgba, plain_metal = make_artwork(DESIGN, look("plain"), 128, 64)
    assert np.array_equal(plain_rgba, make_label(DESIGN, 128, 64)) and not plain_metal.any()
    shares = {}
    for style, metallic in (("designer", False), ("designer", True), ("bare", False)):
        shares[style, metallic] = np.mean([make_artwork(DESIGN, look(style, s, metallic), 256, 128)[1].mean()
                                           for s in range(12)])
    assert shares["designer", False] == 0, "opaque inks only"
    assert shares["designer", True] > 0.002, "metallic inks show silver"
    assert shares["bare", False] > 0.5, "a bare-metal body is mostly aluminium"
    rgba, metal = make_artwork(DESIGN, look("designer", 1), 256, 128)
    assert len(np.unique((rgba[..., :3] * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 200, "fine graphics"


def test_a_taller_label_is_drawn_unstretched_at_the_same_size():
    rgba, metal = make_artwork(DESIGN, look("designer"), 128, 64, aspect=1.6)
    assert rgba.shape == (64, 128, 4) and metal.shape == (64, 128)
    assert not np.array_equal(rgba, make_artwork(DESIGN, look("designer"), 128, 64)[0])


def test_a_photo_becomes_the_artwork(tmp_path):
    path = tmp_path / "art.png"
    x = np.linspace(0, 255, 300).astype(np.uint8)
    Image.fromarray(np.stack([np.tile(x, (200, 1)), np.tile(x[::-1], (200, 1)), np.full((200, 300), 80, np.uint8)],
                             axis=2)).save(path)
    rgba, metal = make_artwork(DESIGN, look("photo", photo=str(path)), 128, 64)
    assert not metal.any()
    assert rgba[..., 2].mean() == pytest.approx(80 / 255, abs=0.15)
    assert rgba[:, 0, 0].mean() < rgba[:, -1, 0].mean(), "the photo's gradient runs across the label"
