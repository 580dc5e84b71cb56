"""Backgrounds: procedural recipes and the cover-resize crop of photos."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.composite.backgrounds import PROCEDURAL_KINDS, fit, load_photo, procedural, scan_backgrounds
from deformsim.errors import UserError


@pytest.mark.parametrize("kind", PROCEDURAL_KINDS)
def test_procedural_is_seeded_varied_and_never_screen_green(kind):
    a, b, c = procedural(kind, 7, 72, 96), procedural(kind, 7, 72, 96), procedural(kind, 8, 72, 96)
    assert a.shape == (72, 96, 3) and a.dtype == np.uint8
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert a.std() > 3  # not flat
    for s in range(20):
        img = procedural(kind, s, 48, 48).astype(int)
        assert (img[..., 1] - np.maximum(img[..., 0], img[..., 2])).max() <= 96


def test_unknown_kind():
    with pytest.raises(UserError, match="plaid"):
        procedural("plaid", 0, 8, 8)


def test_fit_covers_keeps_aspect_and_is_seeded():
    photo = np.zeros((100, 300, 3), np.uint8)
    photo[:, :150] = 200  # left half bright
    out, info = fit(photo, 64, 64, np.random.default_rng(1), (1.0, 1.0), flip=False)
    assert out.shape == (64, 64, 3) and info["bg_scale"] == 1.0
    # a 1:1 crop of a 3:1 photo at scale 1 spans its full height: a third of its width
    assert info["bg_y"] == 0 and 0 <= info["bg_x"] <= 2 / 3
    again, info2 = fit(photo, 64, 64, np.random.default_rng(1), (1.0, 1.0), flip=False)
    assert np.array_equal(out, again) and info == info2
    flips = [fit(photo, 32, 32, np.random.default_rng(s), (1.0, 2.0), flip=True)[1] for s in range(40)]
    assert {f["bg_flip"] for f in flips} == {True, False}
    assert all(1.0 <= f["bg_scale"] <= 2.0 for f in flips)


def test_scan_recursive_and_draft_decode(backgrounds_dir):
    found = scan_backgrounds(backgrounds_dir)
    assert len(found) >= 40 and all(p.suffix.lower() in {".jpg", ".jpeg", ".png"} for p in found)
    small = load_photo(str(found[0]), 64, 64)
    assert min(small.shape[:2]) >= 64 and max(small.shape[:2]) < 1000  # decoded at reduced size


def test_scan_missing(tmp_path):
    with pytest.raises(UserError, match="not found"):
        scan_backgrounds(tmp_path / "nope")
