"""Area lights and view transforms in Blender: hidden lights change nothing, shown ones (a softbox, a ring and an
overhead panel) aim at the part and light it; the view transform reaches Cycles."""

from __future__ import annotations

import dataclasses
import json

import pytest

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import LightParams, sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

SMALL = {"render.resolution": 48, "render.samples": 4, "render.threads": 2, "render.dense": False,
         "camera.azimuth_quadrants": [(20, 70)]}


def test_lights_and_view_transform(tmp_path):
    spec = load_spec(None)
    plain = load_config("quick", SMALL)
    lit = load_config("quick", {**SMALL, "render.view_transform": "Standard", "lighting.area_lights.count": [0, 3]})
    p = sample_params(0, 3, plain, spec, list_hdris(None))
    assert p.lights == ()
    strong = (LightParams(kind="softbox", azimuth=p.cameras[0].azimuth + 30, elevation=40.0, distance=0.6, size=0.4,
                          size_y=0.3, spin=20.0, power=300 * 0.36, temperature=5500.0),
              LightParams(kind="ring", azimuth=p.cameras[0].azimuth, elevation=90 - p.cameras[0].polar,
                          distance=p.cameras[0].radius * 1.1, size=0.2, size_y=0.2, spin=0.0, power=20.0,
                          temperature=6500.0),
              LightParams(kind="overhead", azimuth=10.0, elevation=85.0, distance=0.9, size=1.0, size_y=0.6, spin=30.0,
                          power=150 * 0.81, temperature=5000.0))
    q = dataclasses.replace(p, lights=strong)
    out = run_blender(f"""
import json
import bpy  # noqa: F401  (mathutils comes with bpy)
import numpy as np
from PIL import Image
from mathutils import Vector
from deformsim.blender import worker
from deformsim.blender.scene.lights import scene_lights
from deformsim.blender.passes.render import render_sample
from deformsim.dataset.layout import Layout, image_id
from deformsim.sampling import SampleParams

root = {str(tmp_path)!r}
p, q = (SampleParams.from_dict(json.loads(s)) for s in ({json.dumps(p.to_dict())!r}, {json.dumps(q.to_dict())!r}))

def render(params, name):
    layout = Layout(root + "/" + name)
    render_sample(ctx, params, layout)
    path = layout.image("rgba", image_id(params.index, 0))
    return path.read_bytes(), np.array(Image.open(path)).astype(float)

facts = {{}}
ctx, _, _ = worker.setup({{"config": json.loads({json.dumps(plain.model_dump(mode="json"))!r}), "out": root}})
facts["plain_lights"] = len(scene_lights(ctx.scene))
a, _ = render(p, "a")
ctx, _, _ = worker.setup({{"config": json.loads({json.dumps(lit.model_dump(mode="json"))!r}), "out": root}})
lights = scene_lights(ctx.scene)
facts["made"] = len(lights)
b, dark = render(p, "b")
facts["same_bytes"] = a == b
facts["hidden"] = [o.hide_render for o in lights]
_, bright = render(q, "c")
facts["shown"] = [not o.hide_render for o in lights]
facts["camera_visible"] = [o.visible_camera for o in lights]
aims = []
for o in lights:
    axis = o.matrix_world.to_quaternion() @ Vector((0, 0, -1))
    aims.append(axis.dot((Vector(ctx.target) - o.matrix_world.translation).normalized()))
facts["aim"] = aims
facts["shapes"] = [o.data.shape for o in lights]
facts["heights"] = [o.matrix_world.translation.z - ctx.target[2] for o in lights]
part = (dark[..., 3] == 255) & (bright[..., 3] == 255)
facts["part_pixels"] = int(part.sum())
facts["dark"] = float(dark[..., :3][part].mean())
facts["bright"] = float(bright[..., :3][part].mean())
facts["alpha_same"] = bool((dark[..., 3] == bright[..., 3]).all())
_, dark_again = render(p, "d")
facts["off_again"] = bool((dark_again == dark).all())
worker.configure(ctx, {{**ctx.cfg.render.model_dump(), "view_transform": "AgX", "look": "Punchy"}})
facts["view"] = [ctx.scene.view_settings.view_transform, ctx.scene.view_settings.look]
print(json.dumps(facts))
""")
    assert out["plain_lights"] == 0 and out["made"] == 3
    assert out["same_bytes"], "explicit Standard with hidden area lights renders what the default renders"
    assert out["hidden"] == [True] * 3 and out["shown"] == [True] * 3 and out["camera_visible"] == [False] * 3
    assert min(out["aim"]) > 0.9999, f"lights point at the part: {out['aim']}"
    assert out["shapes"] == ["RECTANGLE", "DISK", "RECTANGLE"]
    assert out["heights"][2] > 0.85 and out["heights"][2] > max(out["heights"][:2])  # the panel hangs above the part
    assert out["part_pixels"] > 100 and out["alpha_same"], "the lights themselves never show in the image"
    assert out["bright"] > out["dark"] + 10, f"lit part {out['bright']:.1f} vs HDRI only {out['dark']:.1f}"
    assert out["off_again"], "a sample without lights after one with lights renders as before"
    assert out["view"] == ["AgX", "AgX - Punchy"]
