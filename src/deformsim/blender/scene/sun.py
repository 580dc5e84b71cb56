"""``lighting.sun``: one Blender sun lamp, made once per worker and set to each sample's
:class:`~deformsim.sampling.sun.SunParams` (hidden where the sample is not lit). A sun's light does not fall off with
distance, so it needs no scaling with the part; it is invisible to camera rays (the film stays transparent around
the part) and its shadows fall on the shadow catcher and the rendered surface like the HDRI's."""

from __future__ import annotations

import math

import bpy
from mathutils import Vector

from deformsim.blender.feature import Feature, RenderContext

NAME = "DeformsimSun"


class Sun(Feature):
    """The sample's hard key light, from its drawn direction towards the part."""

    def __init__(self, ctx: RenderContext):
        super().__init__(ctx)
        data = bpy.data.lights.new(NAME, "SUN")
        data.use_temperature = True
        self.light = bpy.data.objects.new(NAME, data)
        self.light.visible_camera = False
        self.light.hide_render = True
        ctx.scene.collection.objects.link(self.light)

    def apply(self, p, target) -> None:
        s = p.sun
        if s is None:
            raise ValueError(f"sample {p.index} has no sun (drawn without lighting.sun?)")
        az, el = math.radians(s.azimuth), math.radians(s.elevation)
        towards_sun = Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)))
        self.light.rotation_mode = "QUATERNION"
        self.light.rotation_quaternion = (-towards_sun).to_track_quat("-Z", "Y")  # a sun shines along its -Z
        self.light.data.energy = s.strength
        self.light.data.angle = math.radians(s.angle)
        self.light.data.temperature = s.temperature
        self.light.hide_render = s.strength == 0
