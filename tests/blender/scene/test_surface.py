"""render.surface: the part on a textured ground, rendered whole, beside the unchanged rgba render."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.dataset.manifest import rows_for
from deformsim.dataset.rendered import Rendered
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, worker_renders

pytestmark = pytest.mark.blender

CAMERAS = [(20, 70), (200, 250)]
RED = (200, 30, 30)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """Two samples rendered by a worker without surfaces, and by one with surfaces and shadows: on wood and on a
    texture photo (a plain red picture)."""
    root = tmp_path_factory.mktemp("surface")
    (root / "photos").mkdir()
    Image.fromarray(np.full((32, 48, 3), RED, np.uint8)).save(root / "photos" / "red.png")
    base = {**TINY_RENDER, "render.dense": False, "render.render_backgrounds": True, "camera.azimuth_quadrants": CAMERAS}
    surface = {"kinds": ["wood", "photo"], "photos": str(root / "photos")}
    cfgs = {False: load_config("quick", base),
            True: load_config("quick", {**base, "render.shadow": True, "render.surface": surface})}
    p = dataclasses.replace(sample_params(0, 5, cfgs[True], load_spec(None), list_hdris(None)), pose_tilt=90.0)
    kinds = {k: load_config("quick", {**base, "render.surface": {**surface, "kinds": [k]}}) for k in ("wood", "photo")}
    ground = {k: sample_params(0, 5, cfg, load_spec(None), list_hdris(None)).surface for k, cfg in kinds.items()}
    wood, photo = dataclasses.replace(p, surface=ground["wood"]), dataclasses.replace(p, index=1, surface=ground["photo"])
    out = {}
    for on, cfg in cfgs.items():
        layout = Layout(root / str(on))
        out[on] = (layout, worker_renders(root / f"{on}.log", cfg, layout.root, [wood, photo]))
    out["params"] = [wood, photo]
    return out


def _read(layout: Layout, kind: str, cam: int, sample: int = 0) -> np.ndarray:
    return np.array(Image.open(layout.image(kind, image_id(sample, cam))))


def test_reply_names_the_scene_images(scenes):
    assert all(r["kinds"] == ["shadow", "surface"] for r in scenes[True][1]), scenes[True][1]
    assert all(r["kinds"] == [] and r["image_columns"] == [{}, {}] for r in scenes[False][1])
    layout = scenes[True][0]
    for r, p, kind in zip(scenes[True][1], scenes["params"], ("wood", "photo")):
        for c, cols in enumerate(r["image_columns"]):
            assert list(cols) == ["shadow", "surface"]
            assert cols["surface"] == f"images/surface/{image_id(r['done'], c)}.png"
        for row in rows_for(p, layout, Rendered.from_dict(r)):  # the drawn ground beside the scene in the manifest
            assert row["surface"] == f"images/surface/{row['id']}.png"
            assert json.loads(row["surface_params"])["kind"] == kind


def test_rgba_and_variants_unchanged_by_surface(scenes):
    """Sample 1 is rendered after sample 0's surface pass: the camera sees the flat colour again, not the HDRI."""
    for sample in (0, 1):
        for kind in ("rgba", "black", "green"):
            for c in range(len(CAMERAS)):
                assert scenes[True][0].image(kind, image_id(sample, c)).read_bytes() == \
                    scenes[False][0].image(kind, image_id(sample, c)).read_bytes(), (sample, kind, c)


def test_surface_scene_shows_the_part_on_a_textured_ground(scenes):
    layout = scenes[True][0]
    for c in range(len(CAMERAS)):
        scene, rgba = _read(layout, "surface", c).astype(float), _read(layout, "rgba", c)
        assert scene.shape == rgba.shape[:2] + (3,)
        ground = rgba[..., 3] == 0
        assert scene[ground].mean() > 10  # lit ground, not the black camera background
        assert scene[ground].std(axis=0).max() > 3  # a texture and shading, not a flat colour
        part = rgba[..., 3] == 255
        assert np.abs(scene[part] - rgba[part][:, :3]).mean() < 40  # the same part, lit alike (plus bounce light)
        photo = _read(layout, "surface", c, sample=1).astype(float)[ground]
        assert photo[:, 0].mean() > 1.5 * photo[:, 1].mean()  # the red photo lies on the ground


def test_every_procedural_kind_renders_its_own_ground(tmp_path):
    kinds = ["wood", "paper", "concrete", "metal", "cloth", "conveyor"]
    base = {**TINY_RENDER, "render.resolution": 32, "render.samples": 2, "render.dense": False,
            "camera.azimuth_quadrants": [(20, 70)]}
    cfg = load_config("quick", {**base, "render.surface": {}})
    spec, hdris = load_spec(None), list_hdris(None)
    params = [dataclasses.replace(sample_params(0, 1, cfg, spec, hdris), index=i,
                                  surface=sample_params(0, 1, load_config("quick", {**base, "render.surface": {"kinds": [k]}}),
                                                        spec, hdris).surface)
              for i, k in enumerate(kinds)]
    replies = worker_renders(tmp_path / "w.log", cfg, tmp_path, params)
    assert all("done" in r for r in replies), replies
    layout = Layout(tmp_path)
    grounds = []
    for i in range(len(kinds)):
        ground = _read(layout, "rgba", 0, sample=i)[..., 3] == 0
        grounds.append(_read(layout, "surface", 0, sample=i).astype(float)[ground].mean(axis=0))
    for i in range(len(kinds)):
        for j in range(i):
            assert np.abs(grounds[i] - grounds[j]).max() > 2, (kinds[i], kinds[j])  # each kind looks its own
    assert grounds[kinds.index("paper")].mean() > grounds[kinds.index("conveyor")].mean() + 30  # white paper, black belt


BACKDROP = """
import json, math, bpy
from deformsim.blender.scene import surface
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
wall = surface.make_backdrop(scene)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
out = {"hidden_at_start": wall.hide_render}
cam.location = (1.0, 0.0, 0.3)  # a side view from +x: the wall stands 0.5 m behind the part, facing the camera
out["side"] = surface.face_camera(wall, cam, (0.0, 0.0, 0.1), 0.5)
bpy.context.view_layer.update()
normal = wall.matrix_world.to_3x3() @ wall.data.polygons[0].normal
out["side_at"] = list(wall.location) + [abs(normal.x), abs(normal.z), wall.hide_render]
cam.location = (0.1, 0.0, 1.0)  # from above: no wall
out["top"] = [surface.face_camera(wall, cam, (0.0, 0.0, 0.1), 0.5), wall.hide_render]
print(json.dumps(out))
"""


def test_the_backdrop_stands_behind_the_part_in_side_views_only():
    from tests.blender.conftest import run_blender

    out = run_blender(BACKDROP)
    assert out["hidden_at_start"] and out["side"] and out["top"] == [False, True]
    x, y, z, nx, nz, hidden = out["side_at"]
    assert (x, y, z) == pytest.approx((-0.5, 0.0, 0.1), abs=1e-6) and nx == pytest.approx(1.0) and nz < 1e-6
    assert not hidden
