"""Framing: the object fills the requested fraction of the frame after the crop."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.composite.framing import crop_window, frame_matrix, object_box, warp


def _disc(h=128, w=128, cx=40, cy=70, r=12):
    yy, xx = np.mgrid[0:h, 0:w]
    alpha = ((xx - cx) ** 2 + (yy - cy) ** 2 <= r * r).astype(np.float32)
    return np.repeat(alpha[..., None], 3, axis=2) * 200.0, alpha


def reframe(fg, alpha, fill_range, offset, rng):
    m, info = frame_matrix(alpha, fill_range, offset, rng)
    return warp(fg, m), np.clip(warp(alpha, m), 0, 1), info


def test_object_box_of_an_empty_alpha_is_none():
    assert object_box(np.zeros((8, 8))) is None
    assert object_box(np.pad(np.ones((2, 3)), ((1, 5), (2, 3)))) == (2, 1, 5, 3)


@pytest.mark.parametrize("fill", [0.4, 0.6, 0.85])
def test_reframed_object_fills_the_requested_fraction(fill):
    fg, alpha = _disc()
    fg2, a2, info = reframe(fg, alpha, (fill, fill), 0.1, np.random.default_rng(0))
    x0, y0, x1, y1 = object_box(a2)
    assert max(x1 - x0, y1 - y0) / 128 == pytest.approx(fill, abs=0.03)
    assert info["frame_fill"] == fill and a2.max() <= 1.0
    inside = a2 > 0.5
    assert np.allclose(fg2[inside][:, 0] / a2[inside], 200.0, atol=2.0)  # premultiplied colour kept


def test_window_stays_inside_the_image_and_never_exceeds_it():
    rng = np.random.default_rng(1)
    for _ in range(50):
        x, y, side = crop_window((100, 100, 126, 126), (128, 128), float(rng.uniform(0.05, 1)), 0.5, rng)
        assert 0 <= x and 0 <= y and x + side <= 128 + 1e-9 and y + side <= 128 + 1e-9


def test_same_seed_same_frame():
    fg, alpha = _disc()
    a = reframe(fg, alpha, (0.5, 0.9), 0.2, np.random.default_rng(7))
    b = reframe(fg, alpha, (0.5, 0.9), 0.2, np.random.default_rng(7))
    assert np.array_equal(a[1], b[1]) and a[2] == b[2]
