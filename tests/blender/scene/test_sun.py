"""``lighting.sun`` in Blender: a lit sample is brighter where the part is and nowhere else, an unlit one renders as
without the feature."""

from __future__ import annotations

import dataclasses

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

SMALL = {**TINY_RENDER, "render.resolution": 48, "render.dense": False, "camera.azimuth_quadrants": [(20, 70)]}


def test_the_sun_lights_the_part_and_an_unlit_sample_renders_as_without_it(tmp_path):
    plain, sunny = load_config("quick", SMALL), load_config("quick", {**SMALL, "lighting.sun": {}})
    p = sample_params(0, 3, sunny, load_spec(None), list_hdris(None))
    cam = p.cameras[0]
    lit = dataclasses.replace(p, sun=dataclasses.replace(p.sun, strength=8.0, azimuth=cam.azimuth, elevation=45.0))
    unlit = dataclasses.replace(p, index=1, sun=dataclasses.replace(p.sun, strength=0.0))
    replies = worker_renders(tmp_path / "sun.log", sunny, tmp_path / "sun", [lit, unlit])
    replies += worker_renders(tmp_path / "plain.log", plain, tmp_path / "plain", [dataclasses.replace(unlit, sun=None)])
    assert all("done" in r for r in replies), replies

    def rgba(root: str, index: int) -> np.ndarray:
        return np.array(Image.open(Layout(tmp_path / root).image("rgba", image_id(index, 0)))).astype(float)

    a, b = rgba("sun", 0), rgba("sun", 1)
    part = a[..., 3] > 250
    assert part.sum() > 100 and (a[..., 3] == b[..., 3]).all()  # the sun is not in the picture, only on the part
    assert a[part, :3].mean() > b[part, :3].mean() + 10
    same = Layout(tmp_path / "plain").image("rgba", image_id(1, 0)).read_bytes()
    assert Layout(tmp_path / "sun").image("rgba", image_id(1, 0)).read_bytes() == same
