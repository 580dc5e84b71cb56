"""Crease layer (render.creases): Cycles pointiness drives scuffed bare metal on ridges and darker folds."""

from __future__ import annotations

import pytest

from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

NODES = """
import json, bpy
from deformsim.blender.part import materials
from deformsim.blender.passes import dense
from deformsim.blender.part.can import build_can
from deformsim.sampling import MaterialParams
from deformsim.spec.model import Material
bpy.ops.wm.read_factory_settings(use_empty=True)

def pointiness_linked(mat):
    return any(n.type == "NEW_GEOMETRY" and n.outputs["Pointiness"].is_linked for n in mat.node_tree.nodes)

def entry(mat, name, ident):
    node = mat.node_tree.nodes[materials.CREASE_IN + name]
    return next(s for s in node.inputs if s.identifier == ident).default_value

out = {}
can = build_can()
bpy.ops.mesh.primitive_cube_add()
cube = bpy.context.active_object
apply = lambda kind, color, rough: materials.apply_material(cube, Material(kind=kind), MaterialParams(color, rough))
apply("plastic", (0.1, 0.2, 0.3), 0.4)
user = cube.data.materials[0]
out["off"] = [pointiness_linked(m) for m in (can.data.materials["Label"], can.data.materials["Aluminium"], user)]
out["off_bsdf_color_linked"] = materials._bsdf(user).inputs["Base Color"].is_linked
materials.enable_creases(can)
apply("painted", (0.7, 0.1, 0.05), 0.6)
apply("metal", (0.5, 0.4, 0.3), 0.2)  # repeated calls: the layer is added once, values reach its entries
n_nodes = len(user.node_tree.nodes)
apply("metal", (0.5, 0.4, 0.3), 0.2)
out["on"] = [pointiness_linked(m) for m in (can.data.materials["Label"], can.data.materials["Aluminium"], user)]
out["nodes_stable"] = len(user.node_tree.nodes) == n_nodes
out["user_color"] = list(entry(user, "Base Color", "A_Color"))
out["user_metallic"] = entry(user, "Metallic", "A_Float")
out["user_rough"] = entry(user, "Roughness", "A_Float")
label_bsdf = materials._bsdf(can.data.materials["Label"])
src = label_bsdf.inputs["Base Color"]
chain = []  # walk the Base Color mixes back to the label image
while src is not None and src.is_linked:
    node = src.links[0].from_node
    chain.append(node.type)
    src = next((s for s in node.inputs if s.identifier == "A_Color"), None)
out["label_chain"] = chain
for mat in can.data.materials:
    dense._add_aov(mat)  # the dense AOV output still links into a material with the layer
out["aov"] = all(dense.AOV_NODE in m.node_tree.nodes for m in can.data.materials)
print(json.dumps(out))
"""

RENDER = """
import dataclasses, json, sys, tempfile
from pathlib import Path
import bpy, numpy as np
from deformsim.blender import worker
from deformsim.blender.cycles import render_to_array
from deformsim.blender.part import materials
from deformsim.blender.scene import cameras as cams
from deformsim.blender.passes.render import apply_state
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import CanDesign, sample_params

cfg = load_config("quick", {**%(tiny)r, "camera.azimuth_quadrants": [(20, 70)]})
tmp = Path(tempfile.mkdtemp())
ctx, _, _ = worker.setup({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(tmp)})
base = sample_params(0, 5, cfg, ctx.spec, list_hdris(None))
design = CanDesign(hue=0.0, saturation=0.9, value=0.55, accent_hue=0.6, bands=3, band_seed=7, word="COLA")
zk, zd = dict.fromkeys(base.keys, 0.0), dict.fromkeys(base.displacement, 0.0)
states = {"intact": (zk, zd), "deformed": ({**zk, "crush_middle": 0.6}, dict.fromkeys(zd, 1.5))}

def render(name):
    k, d = states[name]
    apply_state(ctx, dataclasses.replace(base, keys=k, displacement=d, seal=0.0, tab=0.0, design=design))
    cam = ctx.cameras[0]
    cams.place(cam, dataclasses.replace(base.cameras[0], radius=0.2), ctx.target, ctx.camera_scale, ctx.obj)
    ctx.scene.camera = cam
    return render_to_array(ctx.scene, tmp / f"{name}.png")[0].astype(float)

off = {n: render(n) for n in states}
materials.enable_creases(ctx.obj)
on = {n: render(n) for n in states}
out = {}
for n in states:
    cover = (off[n][..., 3] == 255) & (on[n][..., 3] == 255)
    a, b = off[n][cover][:, :3], on[n][cover][:, :3]
    out[n] = dict(diff=float(np.abs(a - b).mean()), sat_off=float(np.ptp(a, axis=1).mean()),
                  sat_on=float(np.ptp(b, axis=1).mean()), covered=int(cover.sum()))
print(json.dumps(out))
""" % {"tiny": TINY_RENDER}


def test_crease_layer_only_when_enabled():
    out = run_blender(NODES)
    assert out["off"] == [False, False, False]
    assert not out["off_bsdf_color_linked"], "without creases the user material keeps its constant Base Color"
    assert out["on"] == [True, True, True]
    assert out["nodes_stable"]
    assert out["user_color"] == pytest.approx([0.5, 0.4, 0.3, 1.0])
    assert out["user_metallic"] == pytest.approx(1.0) and out["user_rough"] == pytest.approx(0.2)
    assert out["label_chain"] == ["MIX", "MIX", "TEX_IMAGE"], "label image -> fold darken -> bare metal -> BSDF"
    assert out["aov"]


def test_creases_show_on_a_crinkled_can_only():
    out = run_blender(RENDER)
    intact, deformed = out["intact"], out["deformed"]
    assert intact["covered"] > 300 and deformed["covered"] > 300
    assert intact["diff"] < 0.5, "an intact can must look the same"
    assert deformed["diff"] > 4 * max(intact["diff"], 0.5)
    assert deformed["sat_on"] < deformed["sat_off"], "scuffed ridges are grey bare metal"


ANISOTROPY = """
import json, bpy
from deformsim.blender.part import materials
from deformsim.sampling import MaterialParams
from deformsim.spec.model import Material
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cube_add()
cube = bpy.context.active_object
out = []
for m in (Material(anisotropic=0.6, anisotropic_rotation=0.25), Material(), Material(kind="plastic", anisotropic=0.2)):
    materials.apply_material(cube, m, MaterialParams((0.8, 0.8, 0.8), 0.1))
    bsdf = materials._bsdf(cube.data.materials[0])
    out.append([bsdf.inputs["Anisotropic"].default_value, bsdf.inputs["Anisotropic Rotation"].default_value])
print(json.dumps(out))
"""


def test_the_spec_materials_anisotropy_reaches_the_bsdf_and_resets():
    out = run_blender(ANISOTROPY)
    assert sum(out, []) == pytest.approx([0.6, 0.25, 0.3, 0.0, 0.2, 0.0])  # metal's own 0.3 when none is given


REGIONS = """
import json, bpy, numpy as np
from deformsim.blender.part import materials
from deformsim.errors import UserError
from deformsim.sampling import MaterialParams
from deformsim.spec.model import Spec
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cylinder_add(vertices=16, depth=2.0)
tin = bpy.context.active_object
def spec(**where):
    return Spec.model_validate({"name": "tin", "families": [{"name": "f", "keys": [{"name": "k", "ops": [
        {"op": "squeeze", "axis": "x", "amount": 0.1}]}]}], "material": {"kind": "metal", "regions": [
        {"name": "top", "kind": "plastic", "roughness": [0.5, 0.6], "where": where}]}})
s = spec(min_normal_angle=60, height_band=[0.5, 1])
materials.assign_regions(tin, s)
top = MaterialParams((0.2, 0.3, 0.4), 0.55)
materials.apply_material(tin, s.material, MaterialParams((0.8, 0.8, 0.8), 0.1, regions=(top,)))
n_nodes = [len(m.node_tree.nodes) for m in tin.data.materials]
materials.apply_material(tin, s.material, MaterialParams((0.7, 0.7, 0.7), 0.2, regions=(top,)))
out = {"slots": [m.name for m in tin.data.materials], "nodes_stable": n_nodes == [len(m.node_tree.nodes) for m in
       tin.data.materials]}
out["faces"] = [[p.material_index, round(p.normal.z), round(p.center.z)] for p in tin.data.polygons]
bsdf = materials._bsdf(tin.data.materials[1])
out["top"] = [list(bsdf.inputs["Base Color"].default_value), bsdf.inputs["Roughness"].default_value,
              bsdf.inputs["Metallic"].default_value]
out["wall_rough"] = materials._bsdf(tin.data.materials[0]).inputs["Roughness"].default_value
try:
    materials.assign_regions(tin, spec(min_normal_angle=60, height_band=[0.3, 0.7]))
    out["error"] = ""
except UserError as exc:
    out["error"] = str(exc)
print(json.dumps(out))
"""


def test_a_material_region_gets_its_faces_and_its_own_finish():
    out = run_blender(REGIONS)
    assert out["slots"] == ["ObjectMaterial", "ObjectMaterial:top"] and out["nodes_stable"]
    top = [f for f in out["faces"] if f[0] == 1]
    assert top == [[1, 1, 1]], "only the upward face at the top takes the region"
    assert all(f[0] == 0 for f in out["faces"] if f[1:] != [1, 1]), "the wall and the bottom keep the spec material"
    assert out["top"][0] == pytest.approx([0.2, 0.3, 0.4, 1.0]) and out["top"][1:] == pytest.approx([0.55, 0.0])
    assert out["wall_rough"] == pytest.approx(0.2)
    assert out["error"] == "spec 'tin': material region 'top' selects no face of the mesh"


PRINT = """
import json, tempfile, bpy, numpy as np
from pathlib import Path
from deformsim.blender.cycles import render_to_array
from deformsim.blender.part import materials
from deformsim.sampling import MaterialParams, PrintParams
from deformsim.spec.model import Spec
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cylinder_add(vertices=48, radius=0.5, depth=1.0)
tin = bpy.context.active_object
s = Spec.model_validate({"name": "tin", "families": [{"name": "f", "keys": [{"name": "k", "ops": [
    {"op": "squeeze", "axis": "x", "amount": 0.1}]}]}], "material": {"kind": "metal", "regions": [
    {"name": "top", "kind": "plastic", "color": [[0.8, 0.8, 0.8], [0.8, 0.8, 0.8]], "roughness": [0.6, 0.6],
     "where": {"min_normal_angle": 60}, "print": {}}]}})
materials.assign_regions(tin, s)
scene = bpy.context.scene
scene.render.engine, scene.cycles.samples, scene.render.film_transparent = "CYCLES", 4, True
scene.render.resolution_x = scene.render.resolution_y = 192
scene.world = bpy.data.worlds.new("W")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam)
cam.data.type, cam.data.ortho_scale, cam.location, scene.camera = "ORTHO", 1.1, (0, 0, 3), cam
tmp, out = Path(tempfile.mkdtemp()), {}
for name, mark in (("bare", None), ("ring", PrintParams((0.6, 0.0, 0.0), "ring", 3)), ("bare_again", None),
                   ("dots", PrintParams((0.0, 0.0, 0.0), "dots", 3))):
    top = MaterialParams((0.8, 0.8, 0.8), 0.6, print=mark)
    materials.apply_material(tin, s.material, MaterialParams((0.8, 0.8, 0.8), 0.2, regions=(top,)))
    px = render_to_array(scene, tmp / f"{name}.png")[0].astype(float)
    rgb = px[..., :3][px[..., 3] == 255]
    lum = rgb.mean(1)
    out[name] = {"dark": float((lum < np.median(lum) - 12).mean()), "red": float((rgb[:, 0] > rgb[:, 1] + 12).mean())}
out["images"] = sorted(i.name for i in bpy.data.images if i.name.startswith(materials.PRINT_IMAGE))
print(json.dumps(out))
"""


def test_a_printed_region_shows_its_drawn_marks_in_its_ink_and_a_bare_sample_none():
    out = run_blender(PRINT)
    assert out["bare"]["dark"] < 0.002 and out["bare_again"]["dark"] < 0.002, "no marks, and none left over"
    assert out["ring"]["red"] > 0.004 and out["bare"]["red"] == 0, "the ring in its red ink"
    assert out["dots"]["dark"] > 0.008 and out["dots"]["red"] == 0, "the code in black"
    assert out["images"] == ["Print:ObjectMaterial:top"], "one mask image, for the printed region only"
