"""HDRI world lighting: Environment Texture -> Background, rotated about Z, plus a camera-only flat colour.

The world shader mixes the HDRI with a flat colour through Light Path "Is Camera Ray": camera rays see
the flat colour (black or green for rendered backgrounds) while the HDRI still lights and reflects.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from pathlib import Path

import bpy

from deformsim.hdri import hdri_files

MAX_CACHED = 4  # HDRI images kept loaded at once


class World:
    """The scene's world node tree; :meth:`set` picks the HDRI, rotation, strength and camera colour."""

    def __init__(self, scene, hdri_dir: Path | None):
        self.paths = hdri_files(hdri_dir)  # the driver drew the samples' HDRI names from the same lookup
        self.images: OrderedDict[str, object] = OrderedDict()
        world = bpy.data.worlds.new("HDRI")
        scene.world = world
        nt = world.node_tree
        nt.nodes.clear()
        n = nt.nodes
        coord = n.new("ShaderNodeTexCoord")
        self.mapping = n.new("ShaderNodeMapping")
        self.env = n.new("ShaderNodeTexEnvironment")
        self.hdri_bg = n.new("ShaderNodeBackground")
        self.flat_bg = n.new("ShaderNodeBackground")
        path = n.new("ShaderNodeLightPath")
        mix = n.new("ShaderNodeMixShader")
        out = n.new("ShaderNodeOutputWorld")
        link = nt.links.new
        link(coord.outputs["Generated"], self.mapping.inputs["Vector"])
        link(self.mapping.outputs["Vector"], self.env.inputs["Vector"])
        link(self.env.outputs["Color"], self.hdri_bg.inputs["Color"])
        link(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
        link(self.hdri_bg.outputs["Background"], mix.inputs[1])
        link(self.flat_bg.outputs["Background"], mix.inputs[2])
        link(mix.outputs["Shader"], out.inputs["Surface"])
        self.flat_bg.inputs["Strength"].default_value = 1.0
        self.set_camera_color((0.0, 0.0, 0.0))
        self.mix, self.is_camera = mix, path
        self.sees_hdri = False

    def camera_sees_hdri(self, on: bool) -> None:
        """Camera rays see the HDRI itself (a rendered scene's sky) instead of the flat colour, or back. Only a change
        edits the shader: each edit makes Cycles rebuild the world's light importance map at the next render."""
        if on == self.sees_hdri:
            return
        self.sees_hdri = on
        fac = self.mix.inputs["Fac"]
        for link in list(fac.links):
            self.mix.id_data.links.remove(link)
        fac.default_value = 0.0
        if not on:
            self.mix.id_data.links.new(self.is_camera.outputs["Is Camera Ray"], fac)

    def set(self, hdri: str, rotation_deg: float, strength: float) -> None:
        """A sample's HDRI, seen by camera rays as the flat colour until a pass asks for it (:meth:`camera_sees_hdri`)."""
        self.camera_sees_hdri(False)
        self.env.image = self._image(hdri)
        self.mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_deg))
        self.hdri_bg.inputs["Strength"].default_value = strength

    def set_camera_color(self, rgb_linear: tuple[float, float, float]) -> None:
        """The colour camera rays see where the film is not transparent (linear RGB)."""
        self.flat_bg.inputs["Color"].default_value = (*rgb_linear, 1.0)

    def _image(self, name: str):
        if name not in self.paths:
            raise ValueError(f"unknown HDRI '{name}' (have: {', '.join(self.paths)})")
        if name in self.images:
            self.images.move_to_end(name)
            return self.images[name]
        while len(self.images) >= MAX_CACHED:
            _, old = self.images.popitem(last=False)
            if self.env.image == old:
                self.env.image = None
            bpy.data.images.remove(old)
        img = bpy.data.images.load(str(self.paths[name]), check_existing=False)
        img.use_fake_user = True  # survives orphans_purge between samples
        self.images[name] = img
        return img
