"""The ground the part rests on (``render.surface``): a textured plane, rendered with the part as a whole scene.

One plane (:data:`SURFACE`) is built per worker and kept hidden for the ordinary renders, so ``rgba`` and every
variant made from it stay as they are without surfaces. Per sample it goes under the part's lowest point and
takes one of the procedural materials below (or a texture photo), coloured, scaled, turned and shifted as
drawn (:class:`deformsim.sampling.SurfaceParams`); one more render per camera then shows the part on it under the
sample's HDRI and area lights, with the HDRI visible beyond the plane: shadows, contact occlusion and reflections
all come from the same light. Pattern sizes are metres at the built-in can's scale (``camera_scale`` 1):

- ``wood``: distorted grain bands along the plank, knots of darker rings, a slight bump;
- ``paper``: near-white, a fine fibre noise;
- ``concrete``: two-tone grey noise with dark pores (Voronoi) and a rough bump;
- ``metal``: brushed steel, metallic, streaks stretched along one direction in colour and roughness;
- ``cloth``: a woven pattern of crossed threads, a bump along them;
- ``conveyor``: dark rubber belt with ribs across it and a fine grain;
- ``photo``: a texture photo (a table top, a floor) tiled across the plane, about 0.6 m per tile at scale 1.

With ``render.surface.backdrop`` a matte wall (:data:`BACKDROP`), coloured like the ground but darker, stands that
many part sizes behind the part, turned to face each side view's camera, instead of the HDRI beyond the ground.
"""

from __future__ import annotations

import colorsys
import math
from pathlib import Path

import bpy
import numpy as np

from deformsim.blender.cycles import render_to_array
from deformsim.blender.feature import Feature, RenderContext
from deformsim.blender.scene.ground import make_plane, place, plane_shown
from deformsim.config import REFERENCE_SIZE

SURFACE = "DeformsimSurface"
BACKDROP = "DeformsimBackdrop"
BACKDROP_DARKER = 0.45  # the wall's colour value over the ground's
SIDE_VIEW = 45.0  # degrees from straight down past which a camera sees the wall
PHOTO_TILE = 0.6  # m: the size one texture photo covers on the ground at scale 1 (a table top's width)
# How much darker each kind's dark tone is than its drawn colour (0 = same, 1 = black).
CONTRAST = {"wood": 0.55, "paper": 0.08, "concrete": 0.45, "metal": 0.25, "cloth": 0.5, "conveyor": 0.5}


def make_surface(scene, camera_scale: float = 1.0):
    """The hidden ground plane, linked to ``scene``; its materials are built on first use (:func:`set_surface`)."""
    return make_plane(scene, SURFACE, camera_scale)


def set_surface(plane, obj, target, p, camera_scale: float = 1.0) -> None:
    """Put ``plane`` under the part's current lowest point and give it sample surface ``p``."""
    place(plane, obj, target)
    mat = _material(p.kind)
    nodes = mat.node_tree.nodes
    size = PHOTO_TILE if p.kind == "photo" else 1.0
    scale = p.scale / (camera_scale * size)
    mapping = nodes["map"]
    mapping.inputs["Scale"].default_value = (scale, scale, scale)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(p.rotation))
    mapping.inputs["Location"].default_value = (p.offset[0] * 100.0, p.offset[1] * 100.0, 0.0)
    nodes["bsdf"].inputs["Roughness"].default_value = p.roughness
    if p.kind == "photo":
        nodes["photo"].image = bpy.data.images.load(p.photo, check_existing=True)
        nodes["gain"].inputs["Value"].default_value = p.value  # the photo's brightness: 0.8-1.2
    else:
        light = _linear(colorsys.hsv_to_rgb(p.hue, p.saturation, p.value))
        dark = tuple(c * (1.0 - CONTRAST[p.kind]) for c in light)
        ramp = nodes["ramp"].color_ramp.elements
        ramp[0].color, ramp[1].color = (*dark, 1.0), (*light, 1.0)
    plane.data.materials.clear()
    plane.data.materials.append(mat)


def make_backdrop(scene, camera_scale: float = 1.0):
    """The hidden wall (``render.surface.backdrop``): a plane like the ground's with one matte material."""
    wall = make_plane(scene, BACKDROP, camera_scale)
    mat = bpy.data.materials.new(BACKDROP)
    mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Roughness"].default_value = 0.9
    wall.data.materials.append(mat)
    return wall


def set_backdrop(wall, p) -> None:
    """Colour the wall like sample surface ``p``'s ground (its drawn colour, :data:`BACKDROP_DARKER` as bright)."""
    rgb = _linear(colorsys.hsv_to_rgb(p.hue, p.saturation, min(p.value, 1.0) * BACKDROP_DARKER))
    bsdf = next(n for n in wall.data.materials[0].node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)


def face_camera(wall, camera, target, distance: float) -> bool:
    """Stand the wall upright ``distance`` metres behind ``target`` as seen from ``camera``; False (and hidden) for a
    camera within :data:`SIDE_VIEW` degrees of straight down, which would see it edge on."""
    view = np.asarray(target, float) - np.asarray(camera.location, float)  # cameras have no parent
    flat = np.hypot(view[0], view[1])
    if math.degrees(math.atan2(flat, -view[2])) <= SIDE_VIEW:
        wall.hide_render = True
        return False
    ax, ay = view[0] / flat, view[1] / flat
    wall.location = (target[0] + ax * distance, target[1] + ay * distance, target[2])
    wall.rotation_euler = (math.pi / 2, 0.0, math.atan2(ay, ax) + math.pi / 2)
    wall.hide_render = False
    return True


def render_scene(scene, plane, world, target: Path, last: bool = True) -> tuple[np.ndarray, float]:
    """Render the surface scene of the scene's camera (plane shown, HDRI seen beyond it); return (RGB, seconds).
    The world keeps showing the HDRI to the camera afterwards, so the pass's next camera reuses Cycles' light
    importance map: the caller puts it back. ``last``: see :func:`deformsim.blender.scene.ground.plane_shown`."""
    scene.render.film_transparent = False
    world.camera_sees_hdri(True)
    try:
        with plane_shown(scene, plane, last):
            pixels, seconds = render_to_array(scene, target)
    finally:
        scene.render.film_transparent = True
    return pixels[..., :3], seconds


class Surface(Feature):
    """``render.surface``: ``images/surface/ID.png`` per camera."""

    def __init__(self, ctx: RenderContext):
        super().__init__(ctx)
        self.plane = make_surface(ctx.scene, ctx.camera_scale)
        backdrop = ctx.cfg.render.surface.backdrop
        self.wall = make_backdrop(ctx.scene, ctx.camera_scale) if backdrop is not None else None
        self.target = ctx.target

    def apply(self, p, target) -> None:
        if p.surface is None:
            raise ValueError(f"sample {p.index} has no surface (drawn without render.surface?)")
        set_surface(self.plane, self.ctx.obj, target, p.surface, self.ctx.camera_scale)
        if self.wall is not None:
            set_backdrop(self.wall, p.surface)
        self.target = target

    def render_pass(self, c: int, path: Path, last: bool) -> tuple[np.ndarray, float]:
        if self.wall is not None:
            distance = self.ctx.cfg.render.surface.backdrop * REFERENCE_SIZE * self.ctx.camera_scale
            face_camera(self.wall, self.ctx.scene.camera, self.target, distance)
        try:
            return render_scene(self.ctx.scene, self.plane, self.ctx.world, path, last=last)
        finally:
            if self.wall is not None:
                self.wall.hide_render = True
            if c == len(self.ctx.cameras) - 1:  # the pass's last camera: the next render sees the flat colour again
                self.ctx.world.camera_sees_hdri(False)


def _linear(rgb) -> tuple[float, float, float]:
    return tuple(c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb)


def _material(kind: str):
    """The material of ``kind``, built once per worker (kept across samples by a fake user)."""
    name = f"{SURFACE}:{kind}"
    mat = bpy.data.materials.get(name)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(name)
    mat.use_fake_user = True
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    g = _Graph(nt)
    bsdf = g.node("ShaderNodeBsdfPrincipled", "bsdf")
    g.link(bsdf, "BSDF", g.node("ShaderNodeOutputMaterial"), "Surface")
    coord = g.node("ShaderNodeTexCoord")
    mapping = g.node("ShaderNodeMapping", "map")
    g.link(coord, "Object", mapping, "Vector")
    _BUILDERS[kind](g, mapping, bsdf)
    return mat


class _Graph:
    """Node-building shorthand for one material's node tree."""

    def __init__(self, nt):
        self.nt = nt

    def node(self, kind: str, name: str | None = None, **inputs):
        n = self.nt.nodes.new(kind)
        if name:
            n.name = name
        for key, value in inputs.items():
            n.inputs[key].default_value = value
        return n

    def link(self, a, out, b, inp) -> None:
        self.nt.links.new(a.outputs[out], b.inputs[inp])

    def ramp(self, fac_node, fac_out: str, bsdf, positions=(0.0, 1.0)):
        ramp = self.node("ShaderNodeValToRGB", "ramp")
        ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[1].position = positions
        self.link(fac_node, fac_out, ramp, "Fac")
        self.link(ramp, "Color", bsdf, "Base Color")
        return ramp

    def bump(self, height_node, out: str, bsdf, strength: float, distance: float = 0.001) -> None:
        bump = self.node("ShaderNodeBump", Strength=strength, Distance=distance)
        self.link(height_node, out, bump, "Height")
        self.link(bump, "Normal", bsdf, "Normal")

    def math(self, op: str, a, a_out: str, b=None, b_out: str = "", value: float = 0.0):
        m = self.node("ShaderNodeMath")
        m.operation = op
        self.link(a, a_out, m, 0)
        if b is not None:
            self.link(b, b_out, m, 1)
        else:
            m.inputs[1].default_value = value
        return m


def _wood(g: _Graph, mapping, bsdf) -> None:
    stretch = g.node("ShaderNodeMapping", Scale=(1.0, 6.0, 1.0))  # grain runs along x
    g.link(mapping, "Vector", stretch, "Vector")
    grain = g.node("ShaderNodeTexWave", Scale=2.5, Distortion=10.0, Detail=6.0)
    grain.wave_type, grain.bands_direction = "BANDS", "Y"
    g.link(stretch, "Vector", grain, "Vector")
    fibre = g.node("ShaderNodeTexNoise", Scale=60.0, Detail=3.0)
    g.link(stretch, "Vector", fibre, "Vector")
    fac = g.math("MULTIPLY", grain, "Fac", fibre, "Fac")
    g.ramp(g.math("ADD", fac, "Value", value=0.15), "Value", bsdf, (0.15, 0.6))
    g.bump(grain, "Fac", bsdf, 0.08)


def _paper(g: _Graph, mapping, bsdf) -> None:
    fibre = g.node("ShaderNodeTexNoise", Scale=900.0, Detail=6.0, Roughness=0.7)
    g.link(mapping, "Vector", fibre, "Vector")
    g.ramp(fibre, "Fac", bsdf, (0.3, 0.7))
    g.bump(fibre, "Fac", bsdf, 0.05)


def _concrete(g: _Graph, mapping, bsdf) -> None:
    blotch = g.node("ShaderNodeTexNoise", Scale=12.0, Detail=10.0, Roughness=0.65)
    g.link(mapping, "Vector", blotch, "Vector")
    pores = g.node("ShaderNodeTexVoronoi", Scale=400.0)
    g.link(mapping, "Vector", pores, "Vector")
    holes = g.math("GREATER_THAN", pores, "Distance", value=0.12)  # 0 inside a pore
    fac = g.math("MULTIPLY", blotch, "Fac", holes, "Value")
    g.ramp(fac, "Value", bsdf, (0.3, 0.7))
    g.bump(fac, "Value", bsdf, 0.3)


def _metal(g: _Graph, mapping, bsdf) -> None:
    bsdf.inputs["Metallic"].default_value = 1.0
    brush = g.node("ShaderNodeMapping", Scale=(1.0, 400.0, 1.0))  # streaks along x
    g.link(mapping, "Vector", brush, "Vector")
    streak = g.node("ShaderNodeTexNoise", Scale=2.0, Detail=8.0, Roughness=0.7)
    g.link(brush, "Vector", streak, "Vector")
    g.ramp(streak, "Fac", bsdf, (0.25, 0.75))
    g.bump(streak, "Fac", bsdf, 0.05)


def _cloth(g: _Graph, mapping, bsdf) -> None:
    warp = g.node("ShaderNodeTexWave", Scale=120.0, Distortion=0.5)
    weft = g.node("ShaderNodeTexWave", Scale=120.0, Distortion=0.5)
    warp.wave_type = weft.wave_type = "BANDS"
    warp.bands_direction, weft.bands_direction = "X", "Y"
    g.link(mapping, "Vector", warp, "Vector")
    g.link(mapping, "Vector", weft, "Vector")
    fac = g.math("MAXIMUM", warp, "Fac", weft, "Fac")
    g.ramp(fac, "Value", bsdf, (0.2, 0.9))
    g.bump(fac, "Value", bsdf, 0.4)


def _conveyor(g: _Graph, mapping, bsdf) -> None:
    ribs = g.node("ShaderNodeTexWave", Scale=40.0, Distortion=0.0)
    ribs.wave_type, ribs.bands_direction = "BANDS", "X"
    ribs.wave_profile = "SAW"
    g.link(mapping, "Vector", ribs, "Vector")
    grain = g.node("ShaderNodeTexNoise", Scale=600.0, Detail=4.0)
    g.link(mapping, "Vector", grain, "Vector")
    fac = g.math("MULTIPLY", ribs, "Fac", grain, "Fac")
    g.ramp(fac, "Value", bsdf, (0.1, 0.5))
    g.bump(ribs, "Fac", bsdf, 0.5)


def _photo(g: _Graph, mapping, bsdf) -> None:
    photo = g.node("ShaderNodeTexImage", "photo")
    photo.extension = "MIRROR"  # tiles without seams
    g.link(mapping, "Vector", photo, "Vector")
    gain = g.node("ShaderNodeHueSaturation", "gain")
    g.link(photo, "Color", gain, "Color")
    g.link(gain, "Color", bsdf, "Base Color")


_BUILDERS = {"wood": _wood, "paper": _paper, "concrete": _concrete, "metal": _metal, "cloth": _cloth,
             "conveyor": _conveyor, "photo": _photo}
