"""The object's pose: object and lattice hang from one pivot at the object's centre, which tilts them
together (so the deformation is unchanged) about a horizontal axis."""

from __future__ import annotations

import math

import bpy
from mathutils import Quaternion


def make_pivot(scene, centre, children) -> object:
    pivot = bpy.data.objects.new("Pivot", None)
    scene.collection.objects.link(pivot)
    pivot.location = tuple(centre)
    pivot.rotation_mode = "QUATERNION"
    bpy.context.view_layer.update()
    for child in children:
        child.parent = pivot
        child.matrix_parent_inverse = pivot.matrix_world.inverted()
    return pivot


def set_pose(pivot, tilt_deg: float, axis_deg: float) -> None:
    """Tilt by ``tilt_deg`` about the horizontal axis at azimuth ``axis_deg`` (both in degrees)."""
    a = math.radians(axis_deg)
    pivot.rotation_quaternion = Quaternion((math.cos(a), math.sin(a), 0.0), math.radians(tilt_deg))
