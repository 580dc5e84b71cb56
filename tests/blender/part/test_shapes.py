"""Part shape families (object.shapes): each named can size at its real dimensions, every deformation source on
each shape, and a user mesh's declared variation within its ranges (measured on the built mesh in Blender)."""

from __future__ import annotations

import pytest

from deformsim.sampling import CAN_SIZES
from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

CAN = """
import dataclasses, json, tempfile
from pathlib import Path
import bpy, numpy as np
from deformsim.blender import worker
from deformsim.blender.passes.render import apply_state
from deformsim.blender.scene.cameras import world_vertices
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import CAN_SIZES, ShapeParams, sample_params

from deformsim.blender.part.shapes import Shaper

cfg = load_config("quick", {**%(tiny)r, "object.shapes": {}})
ctx, _, _ = worker.setup({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": tempfile.mkdtemp()})
rest = np.empty(len(ctx.obj.data.vertices) * 3, np.float32)
ctx.obj.data.vertices.foreach_get("co", rest)
squashed = rest.reshape(1, -1, 3) * np.array([1.0, 1.0, 0.7], np.float32)  # a bank entry: the can squashed to 70 %%
ctx.rig.load_bank(["squash/0"], squashed)
ctx.shaper = Shaper(ctx.obj, ctx.rig.lattice, ctx.pivot, ctx.spec.lattice.margin, True)  # as after a bank's loading
base = sample_params(1, 3, cfg, ctx.spec, list_hdris(None))
zk, zd = dict.fromkeys(base.keys, 0.0), dict.fromkeys(base.displacement, 0.0)
crush = {**zk, **{k: 0.5 for k in list(base.keys)[:3]}}
out = {}
for name, dims in CAN_SIZES.items():
    shape = ShapeParams(size=name, scale=(1.0, 1.0, 1.0), taper=0.0, bulge=0.0, **dims)
    p = dataclasses.replace(base, shape=shape, keys=zk, displacement=zd, seal=0.0, tab=0.0, pose_tilt=0.0)
    target = apply_state(ctx, p)
    co = world_vertices(ctx.obj) * 1000
    size = co.max(0) - co.min(0)
    rest = dict(diameter=float(size[:2].max()), height=float(size[2]), bottom=float(co[:, 2].min()),
                centre=[float(v) for v in (co.max(0) + co.min(0)) / 2], target=[1000 * v for v in target])
    apply_state(ctx, dataclasses.replace(p, keys=crush, displacement=dict.fromkeys(zd, 1.0), seal=1.0, tab=1.0))
    moved = world_vertices(ctx.obj) * 1000
    rest["deformed_mm"] = float(np.linalg.norm(moved - co, axis=1).max())
    rest["finite"] = bool(np.isfinite(moved).all())
    apply_state(ctx, dataclasses.replace(p, bank="squash/0", bank_amount=1.0))
    bank = world_vertices(ctx.obj) * 1000
    rest["bank"] = [float(v) for v in bank.max(0) - bank.min(0)]
    out[name] = rest
print(json.dumps(out))
""" % {"tiny": TINY_RENDER}


def test_each_named_can_size_has_its_real_dimensions_and_deforms():
    out = run_blender(CAN)
    for name, dims in CAN_SIZES.items():
        got = out[name]
        assert got["diameter"] == pytest.approx(dims["diameter"], abs=1.0), name
        assert got["height"] == pytest.approx(dims["height"], abs=1.0), name
        assert got["bottom"] == pytest.approx(0.0, abs=1e-3), f"{name} stands on the ground"
        assert got["target"] == pytest.approx(got["centre"], abs=1e-3), "cameras aim at the shaped part's centre"
        assert got["finite"] and got["deformed_mm"] > 3.0, f"lattice, crinkle and openings deform {name}"
        assert got["bank"][2] < got["height"] - 20, f"the bank entry crushes {name}"
        assert max(got["bank"][:2]) == pytest.approx(got["diameter"], abs=1.0), f"a crushed {name} keeps its width"
    assert out["standard355"]["diameter"] == pytest.approx(66.0, abs=1e-3), "standard355 is the can as built"
    assert out["standard355"]["height"] == pytest.approx(122.0, abs=1e-3)


MESH = """
import dataclasses, json, tempfile
import numpy as np
from deformsim.blender import worker
from deformsim.blender.passes.render import apply_state
from deformsim.blender.scene.cameras import world_vertices
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params

shapes = {"scale": [[0.7, 0.9], [1.1, 1.3], [1.2, 1.6]], "taper": [-0.3, 0.3], "bulge": [0.0, 0.2]}
cfg = load_config("quick", {**%(tiny)r, "object.mesh": %(mesh)r, "object.spec": %(spec)r, "object.shapes": shapes})
ctx, _, _ = worker.setup({"config": cfg.model_dump(mode="json"), "spec_path": %(spec)r, "out": tempfile.mkdtemp()})
rest = world_vertices(ctx.obj)
out = {"rest": [float(v) for v in rest.max(0) - rest.min(0)], "samples": []}
for i in range(4):
    p = sample_params(2 * i + 1, 11, cfg, ctx.spec, list_hdris(None))  # intact samples
    apply_state(ctx, dataclasses.replace(p, seal=0.0, tab=0.0, pose_tilt=0.0))  # closed, upright
    co = world_vertices(ctx.obj)
    out["samples"].append({"shape": p.shape.to_dict(), "size": [float(v) for v in co.max(0) - co.min(0)],
                           "bottom": float(co[:, 2].min())})
print(json.dumps(out))
"""


def test_a_mesh_takes_its_declared_variation(carton):
    from tests.util import ROOT

    spec = str(ROOT / "examples" / "carton" / "spec.yaml")
    out = run_blender(MESH % {"tiny": TINY_RENDER, "mesh": str(carton), "spec": spec})
    rest = out["rest"]
    seen = set()
    for s in out["samples"]:
        shape, size = s["shape"], s["size"]
        sx, sy, sz = shape["scale"]
        assert 0.7 <= sx <= 0.9 and 1.1 <= sy <= 1.3 and 1.2 <= sz <= 1.6
        assert -0.3 <= shape["taper"] <= 0.3 and 0.0 <= shape["bulge"] <= 0.2
        assert size[2] == pytest.approx(rest[2] * sz, rel=1e-3), "z extent scales by the drawn factor"
        widest = (1 + abs(shape["taper"])) * (1 + shape["bulge"])  # taper and bulge widen a section by at most this
        for axis, scale in ((0, sx), (1, sy)):
            assert rest[axis] * scale * 0.65 <= size[axis] <= rest[axis] * scale * widest * 1.001
        assert s["bottom"] == pytest.approx(0.0, abs=1e-6), "the part still stands on the ground"
        seen.add(round(size[0], 6))
    assert len(seen) == len(out["samples"]), "every sample has its own shape"
