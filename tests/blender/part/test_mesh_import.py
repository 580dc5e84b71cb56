"""User meshes: units, up axis, size, joining, cleanup and one-line errors naming the file."""

from __future__ import annotations

import itertools

import pytest

from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

IMPORT = """
import json, bpy
from pathlib import Path
from deformsim.blender.part.mesh_import import import_mesh
from deformsim.blender.motion.rig import mesh_bounds
from deformsim.errors import UserError
from deformsim.spec.model import load_spec
base = load_spec(None).model_copy(update=dict(builtin=None))
out = {{}}
for name, path, update in {cases!r}:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    {prepare}
    try:
        obj = import_mesh(Path(path), base.model_copy(update=update))
    except UserError as exc:
        out[name] = dict(error=str(exc))
        continue
    lo = [min(v.co[i] for v in obj.data.vertices) for i in range(3)]
    hi = [max(v.co[i] for v in obj.data.vertices) for i in range(3)]
    low, high = mesh_bounds(obj)
    out[name] = dict(name=obj.name, size=(high - low).tolist(), lo=lo, hi=hi,
                     objects=sorted(o.name for o in bpy.data.objects), verts=len(obj.data.vertices),
                     faces=len(obj.data.polygons), smooth=all(p.use_smooth for p in obj.data.polygons))
print(json.dumps(out))
"""


def _box(lo, hi):
    """The 12 triangles of an axis-aligned box, outward facing."""
    c = [[(lo, hi)[(i >> k) & 1][k] for k in range(3)] for i in range(8)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return [(c[a], c[b], c[d]) for q in quads for a, b, d in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]


def write_ascii_stl(path, boxes):
    lines = ["solid test"]
    for tri in itertools.chain.from_iterable(_box(lo, hi) for lo, hi in boxes):
        lines += ["facet normal 0 0 0", " outer loop"]
        lines += [f"  vertex {x} {y} {z}" for x, y, z in tri]
        lines += [" endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid test", ""]))


def write_obj(path, boxes):
    lines, n = [], 0
    for k, (lo, hi) in enumerate(boxes):
        lines.append(f"o part{k}")
        for tri in _box(lo, hi):
            lines += [f"v {x} {y} {z}" for x, y, z in tri]
            lines.append(f"f {n + 1} {n + 2} {n + 3}")
            n += 3
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("meshes")
    box = d / "box.stl"  # 40 x 20 x 10 mm, far from the origin
    write_ascii_stl(box, [((100, 50, 30), (140, 70, 40))])
    two = d / "two.obj"  # two 10 mm cubes 20 mm apart along x
    write_obj(two, [((0, 0, 0), (10, 10, 10)), ((20, 0, 0), (30, 10, 10))])
    (d / "empty.stl").write_bytes(b"")
    (d / "garbage.ply").write_bytes(b"\x00\x13not a ply file at all" * 20)
    (d / "noise.stl").write_bytes(bytes(range(256)) * 3)
    (d / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    cases = [
        ("mm", str(box), {"units": "mm"}),
        ("yup", str(box), {"units": "mm", "up_axis": "Y"}),
        ("size", str(box), {"units": "mm", "size": 0.5}),
        ("two", str(two), {"units": "cm"}),
        ("empty", str(d / "empty.stl"), {}),
        ("garbage", str(d / "garbage.ply"), {}),
        ("points", str(d / "points.obj"), {}),
        ("noise", str(d / "noise.stl"), {}),
        ("missing", str(d / "nope.stl"), {}),
    ]
    glb = d / "scene.glb"  # exported by Blender with a camera and a light that must not survive import
    prepare = (
        "if name == 'glb': bpy.ops.mesh.primitive_cube_add(size=2.0); "
        "bpy.ops.object.camera_add(location=(5, 0, 0)); bpy.ops.object.light_add(type='POINT'); "
        f"bpy.ops.export_scene.gltf(filepath={str(glb)!r}, export_cameras=True, export_lights=True); "
        "bpy.ops.wm.read_factory_settings(use_empty=True)"
    )
    cases.append(("glb", str(glb), {"units": "m"}))
    return run_blender(IMPORT.format(cases=cases, prepare=prepare))


def test_stl_in_mm_becomes_one_object_in_metres_standing_on_the_origin(imported):
    r = imported["mm"]
    assert r["name"] == "Object" and r["objects"] == ["Object"]
    assert r["size"] == pytest.approx([0.04, 0.02, 0.01], abs=1e-6)
    assert r["lo"][2] == pytest.approx(0, abs=1e-7)
    assert r["lo"][0] == pytest.approx(-r["hi"][0], abs=1e-7) and r["lo"][1] == pytest.approx(-r["hi"][1], abs=1e-7)
    assert r["verts"] == 8 and r["faces"] == 12, "split STL facets are welded"
    assert r["smooth"]


def test_y_up_and_size(imported):
    assert imported["yup"]["size"] == pytest.approx([0.04, 0.01, 0.02], abs=1e-6)
    assert imported["size"]["size"] == pytest.approx([0.5, 0.25, 0.125], abs=1e-6)


def test_several_objects_are_joined(imported):
    r = imported["two"]
    assert r["objects"] == ["Object"] and r["faces"] == 24
    assert r["size"] == pytest.approx([0.3, 0.1, 0.1], abs=1e-6)


def test_gltf_cameras_and_lights_are_dropped(imported):
    r = imported["glb"]
    assert r["objects"] == ["Object"]
    assert r["size"] == pytest.approx([2.0, 2.0, 2.0], abs=1e-5)


@pytest.mark.parametrize("case, words", [
    ("empty", "empty"), ("garbage", "garbage.ply"), ("points", "no faces"), ("noise", "noise.stl"),
    ("missing", "not found"),
])
def test_bad_files_give_one_line_errors_naming_the_file(imported, case, words):
    err = imported[case]["error"]
    assert words in err and "\n" not in err
    assert case in err or "nope.stl" in err
