"""Cameras on a sphere around the object, each aimed at the object's bounding-box centre.

With the per-image framing of ``camera`` (:func:`deformsim.sampling.draw_framing`) :func:`place` also frames
the part as a person with a camera would: the distance along the drawn direction that makes the projected box
of the posed, deformed mesh fill a drawn fraction of the frame (``fill``), a lens shift that moves the box off
the frame centre or across its border (``offset``, ``partial``; no change of perspective), a drawn lens and
depth of field. Every setting is put back to the config's when an image draws none (cameras are reused).
Renders are square: the sensor width (Blender's "auto" fit) spans the frame side.
"""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from deformsim.sampling import CameraParams

LENS_KEY = "deformsim_lens"  # custom property of each camera's data: the config's lens (mm)


def make_cameras(scene, n: int, lens_mm: float, camera_scale: float = 1.0) -> list:
    """Create ``n`` camera objects (placed later by :func:`place`)."""
    cams = []
    for i in range(n):
        data = bpy.data.cameras.new(f"Camera{i}")
        data.lens = lens_mm
        data[LENS_KEY] = float(lens_mm)
        data.clip_start = 0.005 * camera_scale
        data.clip_end = 100.0 * camera_scale
        cam = bpy.data.objects.new(f"Camera{i}", data)
        scene.collection.objects.link(cam)
        cams.append(cam)
    return cams


def camera_location(p: CameraParams, target, camera_scale: float = 1.0) -> Vector:
    """Azimuth about +Z from +X, polar from +Z (degrees); radius in metres times ``camera_scale``."""
    return Vector(target) + _direction(p) * (p.radius * camera_scale)


def place(cam, p: CameraParams, target, camera_scale: float, obj) -> None:
    """Move ``cam`` to ``p`` and aim its -Z axis at ``target`` with +Y up; set its lens, lens shift and depth of
    field from ``p`` (the config's lens, no shift, no DOF where ``p`` draws none). A framed ``p``
    (:attr:`CameraParams.framed`) is placed by the projected box of the part ``obj`` as it is evaluated now, see
    :func:`frame`."""
    data = cam.data
    _set(data, "lens", p.lens if p.lens > 0 else data.get(LENS_KEY, data.lens))
    shift = (0.0, 0.0)
    if p.framed:
        distance, shift = frame(world_vertices(obj), p, target, camera_scale, data.lens, data.sensor_width)
        cam.location = Vector(target) + _direction(p) * distance
    else:
        cam.location = camera_location(p, target, camera_scale)
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (Vector(target) - cam.location).to_track_quat("-Z", "Y")
    _set(data, "shift_x", shift[0])
    _set(data, "shift_y", shift[1])
    _set(data.dof, "use_dof", p.fstop > 0)
    if p.fstop > 0:
        _set(data.dof, "aperture_fstop", p.fstop)
        _set(data.dof, "focus_distance", (cam.location - Vector(target)).length)


def _set(owner, attr: str, value) -> None:
    """Set only a changed value: an image framed as in the paper touches nothing (its render is unchanged)."""
    if getattr(owner, attr) != value:
        setattr(owner, attr, value)


def _direction(p: CameraParams) -> Vector:
    """Unit vector from the target towards the camera."""
    az, pol = math.radians(p.azimuth), math.radians(p.polar)
    return Vector((math.sin(pol) * math.cos(az), math.sin(pol) * math.sin(az), math.cos(pol)))


def world_vertices(obj) -> np.ndarray:
    """World positions (N x 3) of ``obj``'s vertices as evaluated now (shape keys, lattice, pose)."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.empty(len(ev.data.vertices) * 3, dtype=np.float64)
    ev.data.vertices.foreach_get("co", co)
    mw = np.array(ev.matrix_world)
    return co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]


def frame(points: np.ndarray, p: CameraParams, target, camera_scale: float, lens: float,
          sensor: float) -> tuple[float, tuple[float, float]]:
    """(distance from ``target``, Blender lens shift (x, y)) of a camera looking at ``target`` from direction
    ``p.azimuth``/``p.polar`` that frames ``points`` (world, N x 3) as ``p`` asks: the distance makes the
    longer side of their projected box ``p.fill`` of the frame side (bisection; ``p.radius`` when fill is 0),
    the shift puts the box centre at (``p.shift_x``, ``p.shift_y``) from the frame centre or, for a cut image,
    ``p.cut`` of the box past the border on ``p.cut_side``. Lens shift is in frame sides (square renders)."""
    d = np.array(_direction(p))
    rot = np.array(Vector(-d).to_track_quat("-Z", "Y").to_matrix())  # columns: the camera's right, up, back
    rel = np.asarray(points, dtype=np.float64) - np.asarray(target, dtype=np.float64)
    x, y, a = rel @ rot[:, 0], rel @ rot[:, 1], rel @ rot[:, 2]
    k = lens / sensor

    def box(dist: float) -> tuple[float, float, float, float]:
        depth = dist - a
        u, v = k * x / depth, k * y / depth
        return float(u.min()), float(u.max()), float(v.min()), float(v.max())

    def size(dist: float) -> float:
        u0, u1, v0, v1 = box(dist)
        return max(u1 - u0, v1 - v0)

    dist = p.radius * camera_scale
    if p.fill > 0:
        lo = float(a.max()) + 0.005 * camera_scale  # every point in front of the near clip
        hi = max(2.0 * lo, dist)
        for _ in range(200):
            if size(hi) <= p.fill:
                break
            hi *= 2.0
        if size(lo) <= p.fill:  # the box cannot grow that large before the part meets the camera
            hi = lo
        for _ in range(100):  # the box shrinks as the camera backs away
            mid = 0.5 * (lo + hi)
            if hi - lo <= 1e-9 * hi:
                break
            lo, hi = (mid, hi) if size(mid) > p.fill else (lo, mid)
        dist = hi
    u0, u1, v0, v1 = box(dist)
    cu, cv = (u0 + u1) / 2, (v0 + v1) / 2
    want_u, want_v = p.shift_x, p.shift_y
    if p.cut_side in ("left", "right"):
        edge = 0.5 + p.cut * (u1 - u0) - (u1 - u0) / 2  # box centre that puts cut of its width past the border
        want_u = edge if p.cut_side == "right" else -edge
    elif p.cut_side in ("top", "bottom"):
        edge = 0.5 + p.cut * (v1 - v0) - (v1 - v0) / 2
        want_v = edge if p.cut_side == "top" else -edge
    return float(dist), (float(cu - want_u), float(cv - want_v))
