"""render.shadow: the part's shadow on a shadow-catcher ground, written apart from the unchanged rgba render."""

from __future__ import annotations

import dataclasses

import cv2
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

CAMERAS = [(20, 70), (200, 250)]


@pytest.fixture(scope="module")
def shadows(tmp_path_factory):
    """Two samples rendered in turn by a worker with shadows and one without (64 px, 16 spp)."""
    root = tmp_path_factory.mktemp("shadow")
    cfgs = {on: load_config("quick", {**TINY_RENDER, "render.samples": 16, "render.dense": False,
                                      "camera.azimuth_quadrants": CAMERAS, "render.shadow": on}) for on in (False, True)}
    p = sample_params(0, 5, cfgs[True], load_spec(None), list_hdris(None))
    p = dataclasses.replace(p, pose_tilt=80.0)  # lying on its side: a long contact line and a wide shadow
    q = dataclasses.replace(sample_params(1, 5, cfgs[True], load_spec(None), list_hdris(None)), index=1)
    out = {}
    for on, cfg in cfgs.items():
        layout = Layout(root / str(on))
        out[on] = (layout, worker_renders(root / f"{on}.log", cfg, layout.root, [p, q]))
    return out


def _read(layout: Layout, kind: str, cam: int, sample: int = 0) -> np.ndarray:
    return np.array(Image.open(layout.image(kind, image_id(sample, cam))))


def test_reply_names_shadow_only_when_on(shadows):
    assert all(r["kinds"] == ["shadow"] for r in shadows[True][1]) and all(r["kinds"] == [] for r in shadows[False][1])
    assert shadows[True][1][1]["image_columns"][0] == {"shadow": "images/shadow/000001_c0.png"}
    assert not (shadows[False][0].root / "images" / "shadow").exists()


def test_rgba_and_variants_unchanged_by_shadow(shadows):
    for kind in ("rgba", "black", "green"):
        for i in range(2):
            for c in range(len(CAMERAS)):
                assert shadows[True][0].image(kind, image_id(i, c)).read_bytes() == \
                    shadows[False][0].image(kind, image_id(i, c)).read_bytes(), (kind, i, c)


def test_shadow_beside_the_part_and_zero_far_away(shadows):
    layout = shadows[True][0]
    for c in range(len(CAMERAS)):
        shadow, alpha = _read(layout, "shadow", c), _read(layout, "rgba", c)[..., 3]
        assert shadow.dtype == np.uint8 and shadow.shape == alpha.shape
        assert not shadow[alpha == 255].any()  # the part's own pixels carry no shadow
        part = (alpha > 0).astype(np.uint8)
        near = cv2.dilate(part, np.ones((9, 9), np.uint8)).astype(bool) & (alpha == 0)
        assert shadow[near].max() >= 100 and (shadow[near] > 0).mean() > 0.2  # contact shadow around the part
        for corner in (shadow[:6, :6], shadow[:6, -6:], shadow[-6:, :6], shadow[-6:, -6:]):
            assert not corner.any()
