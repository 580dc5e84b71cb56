"""Import a user's CAD mesh through Blender's own importers as one clean object "Object".

STL, OBJ and PLY carry no axis convention: they are read as stored and turned Z-up when the spec says
``up_axis: Y``. glTF and FBX define their axes and Blender's importers already convert them to Z-up.
The result is one joined mesh in metres, transforms applied, centred on the z axis, standing on z = 0.
"""

from __future__ import annotations

import math
from pathlib import Path

import bpy

# isort: split
import bmesh  # importable only once bpy is
import numpy as np

from deformsim.blender.motion.rig import mesh_bounds
from deformsim.errors import UserError
from deformsim.spec.model import Spec, check_mesh_file

NAME = "Object"
_RAW = {"forward_axis": "Y", "up_axis": "Z"}  # identity axes for the formats without a convention
_IMPORTERS = {
    ".stl": lambda p: bpy.ops.wm.stl_import(filepath=p, **_RAW),
    ".obj": lambda p: bpy.ops.wm.obj_import(filepath=p, **_RAW),
    ".ply": lambda p: bpy.ops.wm.ply_import(filepath=p, **_RAW),
    ".glb": lambda p: bpy.ops.import_scene.gltf(filepath=p),
    ".gltf": lambda p: bpy.ops.import_scene.gltf(filepath=p),
    ".fbx": lambda p: bpy.ops.import_scene.fbx(filepath=p),
}
_AXIS_FREE = (".stl", ".obj", ".ply")


def _read(path: Path) -> list[bpy.types.Object]:
    """Run the importer; return the objects it created. Raises UserError if Blender cannot read it."""
    before = set(bpy.data.objects)
    try:
        result = _IMPORTERS[path.suffix.lower()](str(path))
    except (RuntimeError, ValueError, KeyError, IndexError, UnicodeDecodeError) as exc:
        text = str(exc).strip()
        reason = text.splitlines()[-1].removeprefix("Error: ") if text else type(exc).__name__
        raise UserError(f"mesh {path} could not be read: {reason}") from None
    new = [o for o in bpy.data.objects if o not in before]
    if "FINISHED" not in result and not new:
        raise UserError(f"mesh {path} could not be read by Blender's {path.suffix} importer")
    return new


def import_mesh(path: Path, spec: Spec) -> bpy.types.Object:
    """Import ``path`` as one mesh object "Object" scaled by the spec's units (or ``size``), smooth shaded."""
    path = check_mesh_file(path)
    new = _read(path)
    bpy.context.view_layer.update()
    meshes = [o for o in new if o.type == "MESH"]
    bm, lo, hi = bmesh.new(), np.full(3, np.inf), np.full(3, -np.inf)
    for o in meshes:
        me = o.data.copy()
        me.transform(o.matrix_world)
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        if len(co):
            lo, hi = np.minimum(lo, co.reshape(-1, 3).min(0)), np.maximum(hi, co.reshape(-1, 3).max(0))
        bm.from_mesh(me)
        bpy.data.meshes.remove(me)
    leftovers = {o.data for o in new if o.data is not None}
    for o in new:
        bpy.data.objects.remove(o)
    for data in leftovers:
        if data.users == 0 and isinstance(data, bpy.types.Mesh):
            bpy.data.meshes.remove(data)
    if not meshes:
        bm.free()
        raise UserError(f"mesh {path} contains no mesh object")
    if not bm.faces:
        bm.free()
        raise UserError(f"mesh {path} has no faces (not a readable mesh, or only points and edges)")

    diag = float(np.linalg.norm(hi - lo))
    dist = diag * 1e-6 if np.isfinite(diag) and diag > 0 else 1e-9
    bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=dist)  # STL stores split facets
    mesh = bpy.data.meshes.new(NAME)
    bm.to_mesh(mesh)
    bm.free()
    _normalise(mesh, spec, path)
    mesh.shade_smooth()
    mesh.set_sharp_from_angle(angle=math.radians(35))  # CAD edges stay crisp
    obj = bpy.data.objects.new(NAME, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _normalise(mesh: bpy.types.Mesh, spec: Spec, path: Path) -> None:
    """Z-up, metres (or ``spec.size`` for the largest dimension), centred on the z axis with min z = 0."""
    co = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    if spec.up_axis == "Y" and path.suffix.lower() in _AXIS_FREE:
        co = np.column_stack([co[:, 0], -co[:, 2], co[:, 1]])  # +90 degrees about x: Y-up becomes Z-up
    extent = co.max(0) - co.min(0)
    if extent.max() <= 0 or not np.isfinite(extent).all():
        raise UserError(f"mesh {path} has zero or non-finite size")
    scale = spec.size / extent.max() if spec.size else spec.unit_scale
    lo, hi = co.min(0), co.max(0)
    offset = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    mesh.vertices.foreach_set("co", ((co - offset) * scale).astype(np.float32).ravel())
    mesh.update()


def main(argv: list[str] | None = None) -> int:
    """``python -m deformsim.blender.part.mesh_import MESH [SPEC]``: import the mesh and rig it as a worker does;
    print its size and vertex count, or the problem."""
    import json
    import sys

    from deformsim.blender.motion.rig import build_rig
    from deformsim.blender.part.materials import assign_regions
    from deformsim.spec.model import load_spec

    args = sys.argv[1:] if argv is None else argv
    try:
        spec = load_spec(args[1] if len(args) > 1 else None)
        obj = import_mesh(Path(args[0]), spec)
    except UserError as exc:
        print(exc, file=sys.stderr)
        return 2
    lo, hi = mesh_bounds(obj)  # before the rig's lattice modifier
    probed = {"size": (hi - lo).tolist(), "vertices": len(obj.data.vertices)}
    try:
        assign_regions(obj, spec)  # the material regions, vertex rule and opening keys fail here, not mid-run
        build_rig(obj, spec)
    except UserError as exc:
        probed["rig"] = str(exc)  # reported after the checks of the shape itself
    print(json.dumps(probed))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
