"""The procedural can: size, side-wall group, opening keys, UVs, materials and one tiny render."""

from __future__ import annotations

import pytest

from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

FACTS = """
import json, bpy, bmesh, numpy as np
from deformsim.blender.part.can import build_can, LID_Z
from deformsim.blender.part.materials import set_label, apply_material
from deformsim.sampling import CanDesign, MaterialParams
from deformsim.spec.model import Material
bpy.ops.wm.read_factory_settings(use_empty=True)
obj = build_can()
me = obj.data
keys = me.shape_keys.key_blocks
def co(block):
    a = np.empty(len(me.vertices) * 3); block.data.foreach_get("co", a); return a.reshape(-1, 3)
base, seal, tab = co(keys["Basis"]), co(keys["Seal"]), co(keys["Tab"])
g = obj.vertex_groups["side_wall"].index
wall = np.array([any(x.group == g and x.weight == 1.0 for x in v.groups) for v in me.vertices])
mat = np.empty(len(me.polygons), np.int32); me.polygons.foreach_get("material_index", mat)
label_z = [base[list(p.vertices), 2] for p, m in zip(me.polygons, mat) if m == 0]
uv = np.empty(len(me.loops) * 2); me.uv_layers.active.data.foreach_get("uv", uv); uv = uv.reshape(-1, 2)
loop_mat = np.repeat(mat, [p.loop_total for p in me.polygons])
bm = bmesh.new(); bm.from_mesh(me)
manifold = all(e.is_manifold for e in bm.edges)
seal_d, tab_d = seal - base, tab - base
seal_moved, tab_moved = np.linalg.norm(seal_d, axis=1) > 1e-7, np.linalg.norm(tab_d, axis=1) > 1e-7

design = CanDesign(hue=0.0, saturation=0.9, value=0.8, accent_hue=0.6, bands=3, band_seed=7, word="COLA")
set_label(design)
px1 = np.array(bpy.data.images["LabelImage"].pixels[:])
n_images = len(bpy.data.images)
set_label(CanDesign(0.5, 0.5, 0.3, 0.1, 2, 9, "FIZZ"))
px2 = np.array(bpy.data.images["LabelImage"].pixels[:])
tex = me.materials["Label"].node_tree.nodes["LabelImage"]

bpy.ops.mesh.primitive_cube_add()
cube = bpy.context.active_object
apply_material(cube, Material(kind="plastic"), MaterialParams((0.1, 0.2, 0.3), 0.4))
apply_material(cube, Material(kind="metal"), MaterialParams((0.5, 0.5, 0.5), 0.2))
bsdf = cube.data.materials[0].node_tree.nodes["Principled BSDF"]
print(json.dumps(dict(
    name=obj.name, size=(base.max(0) - base.min(0)).tolist(), zmin=float(base[:, 2].min()),
    centre=((base.max(0) + base.min(0))[:2] / 2).tolist(), manifold=manifold,
    wall_z=[float(base[wall, 2].min()), float(base[wall, 2].max())], wall_n=int(wall.sum()),
    wall_r=[float(np.hypot(*base[wall, :2].T).min()), float(np.hypot(*base[wall, :2].T).max())],
    keys=[k.name for k in keys], slots=[m.name for m in me.materials],
    label_z=[float(min(z.min() for z in label_z)), float(max(z.max() for z in label_z))],
    label_uv=[uv[loop_mat == 0].min(0).tolist(), uv[loop_mat == 0].max(0).tolist()],
    seal_dz_max=float(seal_d[:, 2].max()), seal_drop=float(-seal_d[:, 2].min()),
    seal_z=[float(base[seal_moved, 2].min()), float(base[seal_moved, 2].max())],
    seal_r=float(np.hypot(*base[seal_moved, :2].T).max()), seal_n=int(seal_moved.sum()),
    tab_max=float(np.linalg.norm(tab_d, axis=1).max()), tab_zmin=float(base[tab_moved, 2].min()),
    tab_r=float(np.hypot(*base[tab_moved, :2].T).max()), tab_lift=float(tab_d[:, 2].max()),
    tab_dip=float(-tab_d[:, 2].min()), lid_z=LID_Z,
    label_changed=float(np.abs(px1 - px2).max()), n_images=n_images, n_images_after=len(bpy.data.images),
    tex_image=tex.image.name, cube_mats=len(cube.data.materials),
    cube_metallic=bsdf.inputs["Metallic"].default_value, cube_rough=bsdf.inputs["Roughness"].default_value,
)))
"""


@pytest.fixture(scope="module")
def can() -> dict:
    return run_blender(FACTS)


def test_can_is_a_355ml_can_in_metres(can):
    assert can["name"] == "Can"
    assert can["size"] == pytest.approx([0.066, 0.066, 0.122], abs=0.002)
    assert can["zmin"] == pytest.approx(0.0, abs=1e-6)
    assert can["centre"] == pytest.approx([0.0, 0.0], abs=1e-6)
    assert can["manifold"], "every edge should join exactly two faces (closed body, closed tab)"


def test_side_wall_group_is_only_the_straight_wall(can):
    lo, hi = can["wall_z"]
    assert 0.005 < lo and hi < 0.112, "side_wall must not reach the bottom dome, neck, rim or lid"
    assert hi - lo > 0.09
    assert can["wall_r"] == pytest.approx([0.033, 0.033], abs=1e-5)
    assert can["wall_n"] >= 64 * 40


def test_label_material_covers_the_side_wall_with_unit_uvs(can):
    assert can["slots"] == ["Label", "Aluminium"]
    assert can["label_z"] == pytest.approx(can["wall_z"])
    (u0, v0), (u1, v1) = can["label_uv"]
    assert u0 == pytest.approx(0, abs=1e-6) and u1 == pytest.approx(1, abs=1e-6)
    assert v0 == pytest.approx(0, abs=1e-6) and v1 == pytest.approx(1, abs=1e-6)


def test_seal_pushes_only_the_lid_panel_down(can):
    assert can["keys"] == ["Basis", "Seal", "Tab"]
    assert can["seal_dz_max"] <= 1e-7, "no vertex may rise"
    assert 0.003 <= can["seal_drop"] <= 0.004
    assert can["seal_z"] == pytest.approx([can["lid_z"]] * 2, abs=1e-6), "only lid vertices move"
    assert can["seal_r"] < 0.0245 and can["seal_n"] > 64


def test_tab_lifts_the_ring_and_dips_the_nose(can):
    assert can["tab_max"] > 0.010
    assert can["tab_lift"] > 0.010 and 0 < can["tab_dip"] < 0.003
    assert can["tab_zmin"] > can["lid_z"], "only the tab (above the lid) moves"
    assert can["tab_r"] < 0.02


def test_label_image_is_reused_and_rewritten(can):
    assert can["tex_image"] == "LabelImage"
    assert can["n_images_after"] == can["n_images"]
    assert can["label_changed"] > 0.5


def test_user_material_is_created_once_and_updated(can):
    assert can["cube_mats"] == 1
    assert can["cube_metallic"] == pytest.approx(1.0)
    assert can["cube_rough"] == pytest.approx(0.2)


def test_tiny_renders_show_the_can_and_each_new_label(tmp_path):
    """Two renders in one process with persistent data: the second must show the second label."""
    res = run_blender(f"""
import json, math, bpy, numpy as np
from deformsim.blender.part.can import build_can
from deformsim.blender.part.materials import set_label
from deformsim.sampling import CanDesign
bpy.ops.wm.read_factory_settings(use_empty=True)
obj = build_can()
sc = bpy.context.scene
sc.world = bpy.data.worlds.new("W")
cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
sc.collection.objects.link(cam)
sc.camera = cam
cam.location = (0.3, 0.0, 0.12)
cam.rotation_euler = (math.radians(80), 0, math.radians(90))
sc.render.engine = "CYCLES"
sc.cycles.samples = 2
sc.render.resolution_x = sc.render.resolution_y = 64
sc.render.film_transparent = True
sc.render.use_persistent_data = True
sc.render.image_settings.color_mode = "RGBA"
out = []
for i, hue in enumerate((0.0, 0.33)):
    set_label(CanDesign(hue, 0.9, 0.8, 0.6, 1, 7, "COLA"), 128, 64)
    sc.render.filepath = r"{tmp_path}/can%d.png" % i
    bpy.ops.render.render(write_still=True)
    px = np.array(bpy.data.images.load(sc.render.filepath).pixels[:]).reshape(64, 64, 4)
    out.append(dict(cover=float((px[..., 3] > 0.5).mean()), rgb=px[px[..., 3] > 0.5, :3].mean(0).tolist()))
print(json.dumps(out))
""")
    for r in res:
        assert 0.1 < r["cover"] < 0.9, "the can should fill part of the frame"
    (r0, g0, _), (r1, g1, _) = res[0]["rgb"], res[1]["rgb"]
    assert r0 > 1.5 * g0, "the red label should show"
    assert g1 > 1.5 * r1, "the green label should replace it"
