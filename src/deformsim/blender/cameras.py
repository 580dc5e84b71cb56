"""Cameras on a sphere around the object, each aimed at the object's bounding-box centre."""

from __future__ import annotations

import math

import bpy
from mathutils import Vector

from deformsim.sampling import CameraParams


def make_cameras(scene, n: int, lens_mm: float, camera_scale: float = 1.0) -> list:
    """Create ``n`` camera objects (placed later by :func:`place`)."""
    cams = []
    for i in range(n):
        data = bpy.data.cameras.new(f"Camera{i}")
        data.lens = lens_mm
        data.clip_start = 0.005 * camera_scale
        data.clip_end = 100.0 * camera_scale
        cam = bpy.data.objects.new(f"Camera{i}", data)
        scene.collection.objects.link(cam)
        cams.append(cam)
    return cams


def camera_location(p: CameraParams, target, camera_scale: float = 1.0) -> Vector:
    """Azimuth about +Z from +X, polar from +Z (degrees); radius in metres times ``camera_scale``."""
    az, pol, r = math.radians(p.azimuth), math.radians(p.polar), p.radius * camera_scale
    offset = Vector((math.sin(pol) * math.cos(az), math.sin(pol) * math.sin(az), math.cos(pol))) * r
    return Vector(target) + offset


def place(cam, p: CameraParams, target, camera_scale: float = 1.0) -> None:
    """Move ``cam`` to ``p`` and aim its -Z axis at ``target`` with +Y up."""
    cam.location = camera_location(p, target, camera_scale)
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (Vector(target) - cam.location).to_track_quat("-Z", "Y")
