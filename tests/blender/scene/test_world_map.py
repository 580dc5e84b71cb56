"""render.world_map: a coarser light importance map of the HDRI changes only the colour's noise: every label, mask,
dense map, manifest column and the alpha stay the same to the byte."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, assert_same_but_colour, worker_renders

pytestmark = pytest.mark.blender


def test_a_faster_world_map_changes_no_label_mask_map_or_alpha(tmp_path):
    base = {**TINY_RENDER, "render.dense": True, "camera.azimuth_quadrants": [(20, 70), (200, 250)]}
    cfgs = {size: load_config("quick", {**base, "render.world_map": size}) for size in (0, 256)}
    params = [sample_params(i, 3, cfgs[0], load_spec(None), list_hdris(None)) for i in range(2)]
    replies = {size: worker_renders(tmp_path / f"{size}.log", cfg, tmp_path / str(size), params)
               for size, cfg in cfgs.items()}
    pairs = assert_same_but_colour([replies[0], replies[256]], [tmp_path / "0", tmp_path / "256"], 2, 2,
                                   ("mask", "depth", "normal", "deform", "region"))
    for iid, a, b in pairs:
        part = a[..., 3] == 255
        diff = np.abs(a[..., :3].astype(int) - b[..., :3])[part].mean()
        assert 0 < diff < 8, f"{iid}: the colour moved by {diff:.2f} levels on average"  # noise, not another light
