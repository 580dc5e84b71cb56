"""The deformation rig inside Blender: lattice keys move points, crinkle stays on the side wall, rest is exact."""

from __future__ import annotations

import pytest

from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

BUILD = """
import json, numpy as np, bpy
from deformsim.blender import cycles
from deformsim.blender.part.can import build_can
from deformsim.blender.motion.rig import build_rig
from deformsim.spec.model import load_spec
from deformsim.spec.lattice_ops import rest_lattice
cycles.reset()
obj = build_can()
spec = load_spec(None)
base = np.array([v.co[:] for v in obj.data.vertices])
side = obj.vertex_groups['side_wall'].index
in_side = np.array([any(g.group == side and g.weight > 0 for g in v.groups) for v in obj.data.vertices])
rig = build_rig(obj, spec)

def evaluated():
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    mesh = obj.evaluated_get(dg).to_mesh()
    co = np.array([v.co[:] for v in mesh.vertices])
    obj.evaluated_get(dg).to_mesh_clear()
    return co
"""


@pytest.fixture(scope="module")
def rig_facts() -> dict:
    return run_blender(
        BUILD
        + """
lat = rig.lattice.data.shape_keys.key_blocks
basis = np.array([p.co[:] for p in lat['Basis'].data])
moved = {k.name: float(np.abs(np.array([p.co[:] for p in k.data]) - basis).max()) for k in lat if k.name != 'Basis'}
rest_err = float(np.abs(evaluated() - base).max())
mk = obj.data.shape_keys.key_blocks
disp = {}
for t in spec.texture_names:
    d = np.linalg.norm(np.array([p.co[:] for p in mk[t].data]) - base, axis=1)
    disp[t] = {"outside_max": float(d[~in_side].max()), "side_moved": float((d[in_side] > 1e-5).mean()),
               "side_max": float(d[in_side].max())}
rig.set({k: 0.0 for k in spec.key_names} | {spec.key_names[0]: 1.0}, {}, 0, 0)
deformed_err = float(np.abs(evaluated() - base).max())
try:
    rig.set({"nope": 1.0}, {}, 0, 0)
    unknown = "accepted"
except ValueError as e:
    unknown = str(e)
print(json.dumps({"keys": sorted(spec.key_names), "moved": moved, "rest_err": rest_err, "disp": disp,
                  "basis_is_rest": bool(np.allclose(basis, rest_lattice(spec.lattice.points), atol=1e-6)),
                  "deformed_err": deformed_err, "unknown": unknown}))
"""
    )


def test_every_lattice_key_moves_points(rig_facts):
    assert sorted(rig_facts["moved"]) == rig_facts["keys"]
    for name, shift in rig_facts["moved"].items():
        assert shift > 0.02, f"lattice key {name} barely moves its points ({shift:.4f})"
    assert rig_facts["basis_is_rest"]


def test_rest_rig_leaves_mesh_exact_and_keys_deform_it(rig_facts):
    assert rig_facts["rest_err"] < 1e-6  # an intact sample is the undeformed model
    assert rig_facts["deformed_err"] > 0.005  # a full key moves the mesh by millimetres


def test_crinkle_only_moves_side_wall(rig_facts):
    assert rig_facts["disp"], "the can spec declares crinkle textures"
    for name, d in rig_facts["disp"].items():
        assert d["outside_max"] < 1e-7, f"{name} moved top/bottom vertices by {d['outside_max']}"
        assert d["side_moved"] > 0.3, f"{name} moved only {d['side_moved']:.0%} of the side wall"
        assert d["side_max"] > 2e-4


def test_unknown_key_is_rejected(rig_facts):
    assert "nope" in rig_facts["unknown"]


def test_missing_vertex_group_is_a_user_error(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        "name: x\nbuiltin: can\nfamilies: [{name: f, keys: [{name: k, ops: [{op: twist}]}]}]\n"
        "displacement: {vertex_rule: {group: nowhere}, textures: [{name: t}]}\n"
    )
    out = run_blender(
        f"""
import json
from deformsim.blender import cycles
from deformsim.blender.part.can import build_can
from deformsim.blender.motion.rig import build_rig
from deformsim.errors import UserError
from deformsim.spec.model import load_spec
cycles.reset()
try:
    build_rig(build_can(), load_spec({str(spec)!r}))
    print(json.dumps({{"error": None}}))
except UserError as e:
    print(json.dumps({{"error": str(e)}}))
"""
    )
    assert out["error"] and "nowhere" in out["error"]
