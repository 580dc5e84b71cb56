"""render.surface.part_colour: false renders the part's own images without bounces or denoising: every label,
mask, dense map and surface scene stays the same to the byte, and so does the alpha."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, assert_same_but_colour, worker_renders

pytestmark = pytest.mark.blender

SURFACE = {"kinds": ["concrete"], "backdrop": 2.5}


def test_the_part_alone_in_less_colour_changes_no_label_mask_map_or_scene(tmp_path):
    base = {**TINY_RENDER, "render.dense": True, "camera.azimuth_quadrants": [(20, 70), (200, 250)]}
    cfgs = {colour: load_config("quick", {**base, "render.surface": {**SURFACE, "part_colour": colour},
                                          "composite.surface": 1.0}) for colour in (True, False)}
    params = [sample_params(i, 3, cfgs[True], load_spec(None), list_hdris(None)) for i in range(2)]
    replies = {}
    for colour, cfg in cfgs.items():
        replies[colour] = worker_renders(tmp_path / f"{colour}.log", cfg, tmp_path / str(colour), params)
    pairs = assert_same_but_colour([replies[True], replies[False]], [tmp_path / "True", tmp_path / "False"], 2, 2,
                                   ("surface", "mask", "depth", "normal", "deform", "region"))
    for iid, a, b in pairs:
        assert not np.array_equal(a[..., :3], b[..., :3]), iid
