"""Physically simulated deformation: a cloth shell of the part crushed by rigid colliders.

The part is remeshed into an even voxel shell (:func:`make_proxy`) and simulated as stiff cloth with
self-collision, at a normalised size (largest dimension :data:`SIM_SIZE` m; Blender's collision distances
misbehave at a few centimetres). Rigid plates, spheres, cylinders or boxes move on straight keyframed paths
(see :mod:`deformsim.spec.simulation` for the scenarios). Every render-mesh vertex is bound at rest to its
nearest shell triangle (barycentric weights and an offset along the normal) and follows it, so a bank entry
is a position per render vertex.
"""

from __future__ import annotations

import math
import time

import bpy
import numpy as np
from mathutils import Matrix, Quaternion, Vector
from mathutils.bvhtree import BVHTree

from deformsim.spec.simulation import Scenario, Simulation, Variant

SIM_SIZE = 1.2  # metres: the part's largest dimension while simulating
GAP = 0.02  # collider start clearance, in SIM_SIZE units
THICKNESS = 0.008  # collision distance of shell and colliders, in SIM_SIZE units
SETTLE = 3  # frames after the colliders stop
EXPLODED = 0.5  # a vertex this many part sizes outside the rest bounding box means the simulation blew up
STRETCHED = 10.0  # so does a shell edge stretched this many times its rest length (a sharp dent stretches ~5x)
UNSETTLED = 0.06  # per-frame motion (part sizes) in the last frame that means it did not converge


class SimulationError(RuntimeError):
    """A scenario's simulation exploded or did not converge."""


def _co(mesh) -> np.ndarray:
    a = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", a)
    return a.reshape(-1, 3).astype(float)


def _evaluated(obj) -> np.ndarray:
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    try:
        return _co(mesh)
    finally:
        ev.to_mesh_clear()


def _link(obj):
    bpy.context.scene.collection.objects.link(obj)
    return obj


class Rest:
    """The part at simulation scale: its render-mesh copy, the cloth proxy, their bounds and scale.

    ``to_part`` maps simulation coordinates back to the part's object space."""

    def __init__(self, part, sim: Simulation):
        """Copy ``part``'s Basis shape, scaled so its largest dimension is SIM_SIZE, standing on z = 0."""
        self.render = _link(bpy.data.objects.new("BakeRender", part.data.copy()))
        if self.render.data.shape_keys:
            self.render.shape_key_clear()
        co = _co(self.render.data)
        self.lo, self.hi = co.min(0), co.max(0)
        self.scale = SIM_SIZE / float((self.hi - self.lo).max())
        self.centre = (self.lo + self.hi) / 2
        self.offset = np.array([-self.centre[0], -self.centre[1], -self.lo[2]]) * self.scale  # standing on z = 0
        self.render.data.transform(Matrix.Translation(Vector(self.offset)) @ Matrix.Scale(self.scale, 4))
        self.proxy = make_proxy(self.render, SIM_SIZE / sim.resolution)
        self.shell = _co(self.proxy.data)  # the shell at rest (its object transform is the identity)
        self.size = (self.hi - self.lo) * self.scale  # extent at simulation scale (m)

    def to_part(self, co: np.ndarray) -> np.ndarray:
        return (co - self.offset) / self.scale


def make_proxy(render, voxel: float):
    """A voxel-remeshed copy of ``render`` (``voxel`` in its mesh units): an even, closed shell for the cloth."""
    proxy = _link(bpy.data.objects.new("BakeProxy", render.data.copy()))
    mod = proxy.modifiers.new("Remesh", "REMESH")
    mod.mode = "VOXEL"
    mod.voxel_size = voxel
    mod.use_smooth_shade = True
    with bpy.context.temp_override(object=proxy, active_object=proxy, selected_objects=[proxy]):
        bpy.ops.object.modifier_apply(modifier=mod.name)
    return proxy


def _cloth(proxy, sim: Simulation, frames: int) -> None:
    mod = proxy.modifiers.new("Cloth", "CLOTH")
    s = mod.settings
    s.quality = sim.quality
    s.mass = 0.3
    s.tension_stiffness = s.compression_stiffness = s.shear_stiffness = sim.stiffness
    s.bending_stiffness = sim.bending
    s.effector_weights.gravity = 0.0
    c = mod.collision_settings
    c.use_collision = True
    c.distance_min = THICKNESS * SIM_SIZE
    c.use_self_collision = True
    c.self_distance_min = c.distance_min
    c.collision_quality = 3
    mod.point_cache.frame_start = 1
    mod.point_cache.frame_end = frames + SETTLE + 1


def _collider(kind: str, size: float, name: str):
    """A rigid collider: an infinite-enough plate (normal -Z), or a sphere, cylinder or box of ``size`` m."""
    if kind == "plate":
        bpy.ops.mesh.primitive_plane_add(size=4 * SIM_SIZE)
        obj = bpy.context.object
        obj.data.transform(Matrix.Rotation(math.pi, 4, "X"))  # normal faces -Z
    elif kind == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(radius=size / 2, segments=32, ring_count=16)
        obj = bpy.context.object
    elif kind == "cylinder":  # its axis lies along local Y: the edge of a bar hits the part
        bpy.ops.mesh.primitive_cylinder_add(radius=size / 2, depth=3 * SIM_SIZE, vertices=32)
        obj = bpy.context.object
        obj.data.transform(Matrix.Rotation(math.pi / 2, 4, "X"))
    else:  # box: a corner leads along local -Z
        bpy.ops.mesh.primitive_cube_add(size=size)
        obj = bpy.context.object
        corner = Vector((1, 1, 1)).normalized().rotation_difference(Vector((0, 0, -1)))
        obj.data.transform(corner.to_matrix().to_4x4())
    obj.name = name
    obj.modifiers.new("Collision", "COLLISION")
    obj.collision.thickness_outer = THICKNESS * SIM_SIZE
    obj.collision.cloth_friction = 5.0
    return obj


def _move(obj, start: Vector, end: Vector, frames: int, rotation) -> None:
    """Keyframe ``obj`` from ``start`` to ``end`` over ``frames`` (linear), oriented by ``rotation``."""
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = rotation
    prefs = bpy.context.preferences.edit
    old = prefs.keyframe_new_interpolation_type
    prefs.keyframe_new_interpolation_type = "LINEAR"
    try:
        obj.location = start
        obj.keyframe_insert("location", frame=1)
        obj.location = end
        obj.keyframe_insert("location", frame=frames)
    finally:
        prefs.keyframe_new_interpolation_type = old


def _direction(azimuth: float, elevation: float = 0.0) -> Vector:
    a, e = math.radians(azimuth), math.radians(elevation)
    return Vector((math.cos(a) * math.cos(e), math.sin(a) * math.cos(e), math.sin(e)))


def _press(rest: Rest, direction: Vector, travel: float, frames: int, tilt: float = 0.0, tilt_axis: float = 0.0,
           kind: str = "plate", size: float = 0.0, at: Vector | None = None, name: str = "Press") -> None:
    """A collider that starts clear of the part on the side ``direction`` points to (from the part's centre)
    and moves ``travel`` m back towards it; plates face the part, tilted ``tilt`` degrees."""
    direction = direction.normalized()
    centre = Vector((0.0, 0.0, rest.size[2] / 2)) if at is None else at
    verts = rest.shell
    reach = max(float(np.max((verts - np.array(centre)) @ np.array(direction))), 0.0)  # part's extent that way
    obj = _collider(kind, size, name)
    rot = Vector((0, 0, -1)).rotation_difference(-direction)  # local -Z (the leading face) points at the part
    if tilt:
        axis = rot @ _direction(tilt_axis)
        rot = Quaternion(axis, math.radians(tilt)) @ rot
    lead = size / 2 if kind in ("sphere", "cylinder") else (size * math.sqrt(3) / 2 if kind == "box" else 0.0)
    tilt_clear = math.sin(math.radians(abs(tilt))) * float(np.linalg.norm(rest.size[:2])) / 2
    start = centre + direction * (reach + lead + tilt_clear + GAP * SIM_SIZE)
    end = start - direction * (travel + tilt_clear + GAP * SIM_SIZE)
    _move(obj, start, end, frames, rot)


def _ground(rest: Rest, direction: Vector = Vector((0, 0, -1))) -> None:
    """A fixed plate just clear of the part on the side ``direction`` points to (the floor, or a wall)."""
    direction = direction.normalized()
    reach = float(np.max(rest.shell @ np.array(direction)))
    obj = _collider("plate", 0.0, "Ground")
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector((0, 0, -1)).rotation_difference(-direction)
    obj.location = direction * (reach + 2 * THICKNESS * SIM_SIZE)


def _extent(rest: Rest, direction: Vector) -> float:
    """The part's extent along ``direction`` (m, simulation scale)."""
    return float(np.ptp(rest.shell @ np.array(direction.normalized())))


def setup_scenario(rest: Rest, scenario: Scenario, v: Variant, frames: int) -> None:
    """Place and animate the colliders of one variant of ``scenario``."""
    size = rest.size
    if scenario.kind == "axial_crush":
        _ground(rest)
        _press(rest, Vector((0, 0, 1)), v.travel * size[2], frames, tilt=v.tilt, tilt_axis=v.azimuth)
    elif scenario.kind == "lateral_squash":
        d = _direction(v.azimuth)
        for sign in (1, -1):
            _press(rest, d * sign, v.travel * _extent(rest, d) / 2, frames, tilt=v.tilt / 2 * sign, tilt_axis=v.azimuth + 90,
                   name=f"Press{sign}")
    elif scenario.kind == "impact_dent":
        d = _direction(v.azimuth)
        at = Vector((0.0, 0.0, v.height * size[2]))
        _ground(rest, -d)
        _press(rest, d, v.travel * _extent(rest, d), frames, kind=scenario.impactor, size=v.size * SIM_SIZE, at=at)
    else:  # crumple: plates from several directions at once, a fist around the part
        for j, az in enumerate(v.directions):
            d = _direction(az, v.elevations[j])
            _press(rest, d, v.travel * _extent(rest, d) / 2, frames, tilt=v.tilt, tilt_axis=az + 90, name=f"Press{j}")


def simulate(part, sim: Simulation, scenario: Scenario, v: Variant) -> tuple[np.ndarray, dict]:
    """Run one variant on a fresh copy of ``part`` (its Basis shape); return the render mesh's new
    vertex positions (object space, float32) and the entry's statistics. Raises :class:`SimulationError`."""
    scene = bpy.context.scene
    rest = Rest(part, sim)
    frames = sim.frames
    _cloth(rest.proxy, sim, frames)
    setup_scenario(rest, scenario, v, frames)
    scene.frame_start, scene.frame_end = 1, frames + SETTLE + 1
    scene.frame_set(1)
    start = _co(rest.render.data)
    binding = bind(rest.shell, _triangles(rest.proxy.data), start)
    t0 = time.perf_counter()
    for f in range(2, frames + SETTLE + 1):
        scene.frame_set(f)
    before = _evaluated(rest.proxy)
    scene.frame_set(frames + SETTLE + 1)
    after = _evaluated(rest.proxy)
    seconds = time.perf_counter() - t0
    start, moved = rest.to_part(start), rest.to_part(follow(binding, after))
    where = f"scenario '{scenario.name}' entry {v.index}"
    if not np.isfinite(moved).all() or len(moved) != len(start):
        raise SimulationError(f"{where}: the simulation exploded (non-finite vertices)")
    size = float(np.ptp(start, axis=0).max())
    outside = float(np.max(np.maximum(start.min(0) - moved, moved - start.max(0)))) / size
    stretch = _stretch(rest, after)
    if outside > EXPLODED or stretch > STRETCHED:
        raise SimulationError(f"{where}: the simulation exploded (a vertex {outside:.2f} part sizes outside the "
                              f"part's box, an edge stretched {stretch:.1f}x)")
    disp = np.linalg.norm(moved - start, axis=1)
    step = float(np.linalg.norm(after - before, axis=1).max()) / SIM_SIZE
    if step > UNSETTLED:
        raise SimulationError(f"{where}: the simulation did not converge (still moving {step:.3f}x the part size "
                              "per frame after the colliders stopped)")
    area, crossing = _shell_checks(rest, after)
    stats = {"seconds": round(seconds, 3), "max_disp_mm": round(float(disp.max()) * 1000, 3),
             "height_ratio": round(float(np.ptp(moved[:, 2]) / np.ptp(start[:, 2])), 4), "stretch": round(stretch, 3),
             "area_ratio": round(area, 4), "intersecting_faces": round(crossing, 5)}
    _clear(rest)
    return moved.astype(np.float32), stats


def _triangles(mesh) -> np.ndarray:
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


def bind(shell: np.ndarray, tris: np.ndarray, points: np.ndarray) -> tuple:
    """Attach each point to its nearest shell triangle: (triangle vertex indices, barycentric weights, signed
    offset along the triangle's normal), so that :func:`follow` carries it along when the shell deforms."""
    tree = BVHTree.FromPolygons([tuple(v) for v in shell], [tuple(t) for t in tris])
    hits = [tree.find_nearest(tuple(p)) for p in points]
    nearest = np.array([h[0][:] for h in hits])
    face = np.array([h[2] for h in hits])
    corners = tris[face]
    a, b, c = (shell[corners[:, k]] for k in range(3))
    v0, v1, v2 = b - a, c - a, nearest - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = np.where(np.abs(d00 * d11 - d01 ** 2) > 1e-20, d00 * d11 - d01 ** 2, 1.0)
    wb, wc = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    weights = np.stack([1 - wb - wc, wb, wc], axis=1)
    offset = ((points - nearest) * _normals(a, b, c)).sum(1)
    return corners, weights, offset


def follow(binding: tuple, shell: np.ndarray) -> np.ndarray:
    """The bound points on the deformed ``shell`` (positions of the same vertices)."""
    corners, weights, offset = binding
    a, b, c = (shell[corners[:, k]] for k in range(3))
    return a * weights[:, :1] + b * weights[:, 1:2] + c * weights[:, 2:] + _normals(a, b, c) * offset[:, None]


def _normals(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    n = np.cross(b - a, c - a)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)


def _stretch(rest: Rest, moved: np.ndarray) -> float:
    """The largest ratio of a shell edge's length in ``moved`` to its rest length (at least half the median edge)."""
    ev = np.empty(len(rest.proxy.data.edges) * 2, np.int32)
    rest.proxy.data.edges.foreach_get("vertices", ev)
    a, b = ev[0::2], ev[1::2]
    before = np.linalg.norm(rest.shell[a] - rest.shell[b], axis=1)
    floor = 0.5 * float(np.median(before))  # the remesher leaves a few tiny edges: measure them against a typical one
    return float(np.max(np.linalg.norm(moved[a] - moved[b], axis=1) / np.maximum(before, floor)))


def _shell_checks(rest: Rest, moved: np.ndarray) -> tuple[float, float]:
    """The shell's area after / before, and the fraction of its faces that cross a face they share no vertex with."""
    polys = [tuple(p.vertices) for p in rest.proxy.data.polygons]

    def area(co: np.ndarray) -> float:
        return sum(float(np.linalg.norm(np.cross(co[p[i]] - co[p[0]], co[p[i + 1]] - co[p[0]]))) / 2
                   for p in polys for i in range(1, len(p) - 1))

    tree = BVHTree.FromPolygons([tuple(v) for v in moved], polys)
    crossing = {i for pair in tree.overlap(tree) if not set(polys[pair[0]]) & set(polys[pair[1]]) for i in pair}
    return area(moved) / area(rest.shell), len(crossing) / len(polys)


def _clear(rest: Rest) -> None:
    for obj in list(bpy.data.objects):
        if obj.name.startswith(("Bake", "Press", "Ground")):
            bpy.data.objects.remove(obj)
    bpy.data.orphans_purge(do_local_ids=True, do_recursive=True)
