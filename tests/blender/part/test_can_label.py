"""Procedural can labels: format, determinism, variety, seamless wrap and printed content."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from deformsim.blender.part.can_label import make_label
from deformsim.errors import UserError
from deformsim.sampling import CanDesign

DESIGN = CanDesign(hue=0.02, saturation=0.9, value=0.8, accent_hue=0.6, bands=3, band_seed=7, word="COLA")


def test_format():
    img = make_label(DESIGN, 256, 128)
    assert img.shape == (128, 256, 4) and img.dtype == np.float32
    assert img.min() >= 0 and img.max() <= 1
    assert np.all(img[..., 3] == 1)


def test_deterministic_and_designs_differ():
    a = make_label(DESIGN, 256, 128)
    assert np.array_equal(a, make_label(DESIGN, 256, 128))
    for change in ({"hue": 0.5}, {"band_seed": 8}, {"word": "FIZZ"}, {"bands": 1}, {"accent_hue": 0.1}):
        b = make_label(replace(DESIGN, **change), 256, 128)
        assert np.abs(a - b).mean() > 0.002, change


def test_base_colour_dominates():
    img = make_label(DESIGN, 256, 128)[..., :3].reshape(-1, 3)
    red = np.mean((img[:, 0] > 0.6) & (img[:, 1] < 0.3) & (img[:, 2] < 0.3))
    assert red > 0.3, "a red design should be mostly red"


def test_wrap_is_seamless():
    """Bands run continuously across u = 0 / 1: the first and last columns nearly match."""
    for seed in range(10):
        img = make_label(replace(DESIGN, band_seed=seed, bands=4), 512, 256)
        seam = np.abs(img[:, 0] - img[:, -1]).mean()
        inside = np.abs(img[:, 100] - img[:, 101]).mean()
        assert seam < 0.05, seed
        assert seam <= inside + 0.05


def test_printed_blocks():
    """The brand word is at the front (u ~ 0.3); a white barcode/nutrition block sits at the back."""
    plain = replace(DESIGN, bands=0)
    img = make_label(plain, 512, 256)[..., :3]
    word_only = make_label(replace(plain, word="I"), 512, 256)[..., :3]
    front = np.abs(img - word_only)[:, 100:210].mean()
    assert front > 0.05, "a longer brand word covers more of the front"
    back = img[:, 300:400]
    white = np.all(back > 0.9, axis=2).mean()
    black = np.all(back < 0.1, axis=2).mean()
    assert white > 0.1 and black > 0.02, "nutrition panel and barcode print white and black"


def test_top_row_is_top():
    """Row 0 is the top of the can: the barcode is printed below the nutrition panel."""
    img = make_label(replace(DESIGN, bands=0), 512, 256)[:, 318:378, :3]
    bars = np.all(img < 0.1, axis=2).mean(axis=1)  # fraction of black per row
    rows = np.flatnonzero(bars > 0.3)
    assert len(rows) > 20 and rows.min() > 128, "barcode rows lie in the lower half"


def test_too_small():
    with pytest.raises(UserError, match="4x4"):
        make_label(DESIGN, 4, 4)
