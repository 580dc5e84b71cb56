"""Framing like a person with a camera (camera.fill, offset, partial, lens range, fstop) at render time."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

RES = 64

PLACE = """
import dataclasses, json, tempfile
from pathlib import Path
import bpy, numpy as np
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from deformsim.blender import worker
from deformsim.blender.scene import cameras as cams
from deformsim.blender.passes.render import apply_state
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import CameraParams, sample_params

cfg = load_config("quick", {"render.resolution": 32, "camera.fill": [0.5, 0.8], "camera.offset": 0.2,
                            "camera.partial": 0.5, "camera.lens_mm": [30, 90], "camera.fstop": [2, 8]})
ctx, _, _ = worker.setup({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": tempfile.mkdtemp()})
out = {"images": []}
for index in range(3):
    p = sample_params(index, 5, cfg, ctx.spec, list_hdris(None))
    target = apply_state(ctx, p)
    pts = cams.world_vertices(ctx.obj)
    for cam, cp in zip(ctx.cameras, p.cameras):
        cams.place(cam, cp, target, ctx.camera_scale, ctx.obj)
        bpy.context.view_layer.update()
        uv = np.array([tuple(world_to_camera_view(ctx.scene, cam, Vector(v)))[:2] for v in pts]) - 0.5
        d = cam.data
        out["images"].append({"p": dataclasses.asdict(cp), "lo": uv.min(0).tolist(), "hi": uv.max(0).tolist(),
                              "lens": d.lens, "dof": d.dof.use_dof, "fstop": d.dof.aperture_fstop,
                              "focus": d.dof.focus_distance, "dist": (cam.location - Vector(target)).length})
# the paper's camera on a reused camera object: config lens, no shift, no DOF, at the drawn radius
plain = CameraParams(azimuth=30.0, polar=60.0, radius=0.4)
cam = ctx.cameras[0]
cams.place(cam, plain, ctx.target, ctx.camera_scale, ctx.obj)
want = cams.camera_location(plain, ctx.target, ctx.camera_scale)
out["plain"] = {"lens": cam.data.lens, "shift": [cam.data.shift_x, cam.data.shift_y], "dof": cam.data.dof.use_dof,
                "at": (cam.location - want).length}
print(json.dumps(out))
"""


def test_place_frames_the_evaluated_part_as_drawn_and_resets_reused_cameras():
    """Blender's own projection of the posed, deformed mesh: fill, offset and cut as drawn; lens and DOF set."""
    out = run_blender(PLACE)
    cut = 0
    for im in out["images"]:
        p, (u0, v0), (u1, v1) = im["p"], im["lo"], im["hi"]
        w, h = u1 - u0, v1 - v0
        assert max(w, h) == pytest.approx(p["fill"], abs=1e-3)
        assert im["lens"] == pytest.approx(p["lens"], abs=1e-4) and 30 <= im["lens"] <= 90
        assert im["dof"] and im["fstop"] == pytest.approx(p["fstop"], abs=1e-4)
        assert im["focus"] == pytest.approx(im["dist"], rel=1e-4)
        side = p["cut_side"]
        if side == "none":
            assert ((u0 + u1) / 2, (v0 + v1) / 2) == pytest.approx((p["shift_x"], p["shift_y"]), abs=1e-3)
            continue
        cut += 1
        past = {"right": (u1 - 0.5) / w, "left": (-0.5 - u0) / w, "top": (v1 - 0.5) / h, "bottom": (-0.5 - v0) / h}
        assert past[side] == pytest.approx(p["cut"], abs=1e-3), f"{side}: {past[side]:.3f} of the box past the border"
        other = (v0 + v1) / 2 if side in ("left", "right") else (u0 + u1) / 2
        assert other == pytest.approx(p["shift_y"] if side in ("left", "right") else p["shift_x"], abs=1e-3)
    assert 0 < cut < len(out["images"])
    # a drawn lens is reset to the config's (the middle of a lens_mm range) where an image draws none
    assert out["plain"] == {"lens": 60.0, "shift": [0.0, 0.0], "dof": False, "at": pytest.approx(0, abs=1e-6)}


def test_rendered_part_fills_the_drawn_fraction(tmp_path):
    """One sample, four cameras, 64 px, 2 spp, depth of field on: the part's alpha box fills the drawn fraction of
    the frame (within 0.05) and, with no offset, sits in the middle (within 3 px)."""
    cfg = load_config("quick", {"render.resolution": RES, "render.samples": 2, "render.threads": 2,
                                "camera.fill": [0.5, 0.8], "camera.fstop": [8, 11]})
    p = sample_params(0, 5, cfg, load_spec(None), list_hdris(None))
    fills = [c.fill for c in p.cameras]
    assert min(fills) < 0.6 and max(fills) > 0.7, fills  # the draw spans the range
    layout = Layout(tmp_path)
    w = WorkerProcess(tmp_path / "w.log", threads=2)
    try:
        w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(layout.root)})
        reply = w.render(p.to_dict())
    finally:
        w.close()
    assert reply.get("done") == 0, reply
    for c, cam in enumerate(p.cameras):
        alpha = np.array(Image.open(layout.image("rgba", image_id(0, c))))[..., 3] > 127
        ys, xs = np.nonzero(alpha)
        side = max(xs.max() - xs.min() + 1, ys.max() - ys.min() + 1) / RES
        assert side == pytest.approx(cam.fill, abs=0.05), f"camera {c}: fills {side:.3f}, drawn {cam.fill:.3f}"
        centre = ((xs.max() + xs.min() + 1) / 2, (ys.max() + ys.min() + 1) / 2)
        assert centre == pytest.approx((RES / 2, RES / 2), abs=3), f"camera {c}: box centre {centre}"
