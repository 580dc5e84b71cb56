"""Area lights on top of the HDRI world (``lighting.area_lights``): softboxes, ring lights, windows and overhead
panels (a ceiling light or inspection hood above the part).

:func:`make_lights` creates the most lights a sample can have once, in the worker; :func:`set_lights` puts
sample's :class:`~deformsim.sampling.LightParams` on them and hides the rest. Lights are invisible to camera
rays (the film stays transparent around the part) but show in the part's reflections.
"""

from __future__ import annotations

import math

import bpy
from mathutils import Euler, Vector

from deformsim.blender.feature import Feature, RenderContext
from deformsim.sampling import LightParams

PREFIX = "AreaLight"
SHAPES = {"softbox": "RECTANGLE", "window": "RECTANGLE", "ring": "DISK", "overhead": "RECTANGLE"}


def make_lights(scene, n: int) -> list:
    """Create ``n`` hidden area lights named AreaLight0.. (placed later by :func:`set_lights`)."""
    out = []
    for i in range(n):
        data = bpy.data.lights.new(f"{PREFIX}{i}", "AREA")
        data.use_temperature = True
        obj = bpy.data.objects.new(f"{PREFIX}{i}", data)
        obj.visible_camera = False  # the light itself never appears in the image, only in reflections
        obj.hide_render = True
        scene.collection.objects.link(obj)
        out.append(obj)
    return out


def scene_lights(scene) -> list:
    """The area lights :func:`make_lights` created, in order."""
    found = {o.name: o for o in scene.collection.objects if o.name.startswith(PREFIX) and o.type == "LIGHT"}
    return [found[f"{PREFIX}{i}"] for i in range(len(found)) if f"{PREFIX}{i}" in found]


def light_location(p: LightParams, target, scale: float = 1.0) -> Vector:
    az, el, r = math.radians(p.azimuth), math.radians(p.elevation), p.distance * scale
    return Vector(target) + Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))) * r


def set_lights(scene, lights: tuple[LightParams, ...], target, scale: float = 1.0) -> None:
    """Show one area light per entry of ``lights`` (creating more when the scene has too few), each aimed at
    ``target`` (its -Z axis), sized and placed times ``scale`` and with its power times ``scale`` squared."""
    objs = scene_lights(scene)
    if len(objs) < len(lights):
        objs += make_lights(scene, len(lights) - len(objs))
    for obj, p in zip(objs, lights):
        data = obj.data
        data.shape = SHAPES[p.kind]
        data.size = p.size * scale
        data.size_y = p.size_y * scale
        data.energy = p.power * scale**2
        data.temperature = p.temperature
        obj.location = light_location(p, target, scale)
        aim = (Vector(target) - obj.location).to_track_quat("-Z", "Y")
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = aim @ Euler((0.0, 0.0, math.radians(p.spin))).to_quaternion()
        obj.hide_render = False
    for obj in objs[len(lights):]:
        obj.hide_render = True


class AreaLights(Feature):
    """``lighting.area_lights``: the most lights a sample can have, made once, shown as each sample draws them."""

    def __init__(self, ctx: RenderContext):
        super().__init__(ctx)
        make_lights(ctx.scene, ctx.cfg.lighting.area_lights.count[1])

    def apply(self, p, target) -> None:
        set_lights(self.ctx.scene, p.lights, target, self.ctx.camera_scale)
