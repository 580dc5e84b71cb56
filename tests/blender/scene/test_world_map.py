"""render.world_map: a coarser light importance map of the HDRI changes only the colour's noise: every label, mask,
dense map, manifest column and the alpha stay the same to the byte."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, worker_renders

pytestmark = pytest.mark.blender


def test_a_faster_world_map_changes_no_label_mask_map_or_alpha(tmp_path):
    base = {**TINY_RENDER, "render.dense": True, "camera.azimuth_quadrants": [(20, 70), (200, 250)]}
    cfgs = {size: load_config("quick", {**base, "render.world_map": size}) for size in (0, 256)}
    params = [sample_params(i, 3, cfgs[0], load_spec(None), list_hdris(None)) for i in range(2)]
    replies = {size: worker_renders(tmp_path / f"{size}.log", cfg, tmp_path / str(size), params)
               for size, cfg in cfgs.items()}
    drop = {"render_seconds", "seconds"}
    strip = [[{k: v for k, v in r.items() if k not in drop} for r in replies[s]] for s in cfgs]
    assert strip[0] == strip[1]  # the same manifest columns: labels, bounding boxes, region shares, displacements
    auto, coarse = Layout(tmp_path / "0"), Layout(tmp_path / "256")
    for sample in range(2):
        for c in range(2):
            iid = image_id(sample, c)
            for kind in ("mask", "depth", "normal", "deform", "region"):
                assert auto.image(kind, iid).read_bytes() == coarse.image(kind, iid).read_bytes(), (kind, iid)
            a, b = (np.array(Image.open(layout.image("rgba", iid))).astype(int) for layout in (auto, coarse))
            assert np.array_equal(a[..., 3], b[..., 3])
            part = a[..., 3] == 255
            diff = np.abs(a[..., :3] - b[..., :3])[part].mean()
            assert 0 < diff < 8, f"{iid}: the colour moved by {diff:.2f} levels on average"  # noise, not another light
