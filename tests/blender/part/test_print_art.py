"""Printed marks of a spec finish's ``print`` (pure numpy + PIL, no Blender)."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.blender.part.print_art import make_print
from deformsim.sampling import PrintParams


@pytest.mark.parametrize("style", ["ring", "lines", "dots"])
def test_each_style_prints_some_ink_deterministically_and_differs_by_seed(style):
    a, b = make_print(PrintParams((0, 0, 0), style, 4), 256), make_print(PrintParams((0, 0, 0), style, 4), 256)
    assert a.shape == (256, 256) and a.dtype == np.float32 and np.array_equal(a, b)
    assert 0 <= a.min() and 0.9 < a.max() <= 1
    assert 0.002 < (a > 0.5).mean() < 0.1, "marks, not a blank or a filled square"
    assert not np.array_equal(a, make_print(PrintParams((0, 0, 0), style, 5), 256))


@pytest.mark.parametrize("style", ["ring", "lines", "dots"])
def test_marks_stay_inside_the_circle_an_upright_round_parts_end_fills(style):
    for seed in range(10):
        mask = make_print(PrintParams((0, 0, 0), style, seed), 200)
        y, x = np.nonzero(mask > 0.1)
        r = np.hypot(x + 0.5 - 100, y + 0.5 - 100) / 200
        assert r.max() < 0.45, f"{style} seed {seed}: ink at {r.max():.2f} of the side from the centre (rim at 0.5)"


def test_a_ring_runs_around_the_centre():
    mask = make_print(PrintParams((0, 0, 0), "ring", 1), 256)
    y, x = np.nonzero(mask > 0.5)
    turn = np.arctan2(y - 128, x - 128)
    assert len(np.unique(np.floor((turn + np.pi) / (2 * np.pi) * 8))) == 8, "ink in every eighth of the turn"
    r = np.hypot(x - 128, y - 128) / 256
    assert 0.12 < r.min() and r.max() < 0.4
