"""Render one sample: set the rig, label or material, world and cameras; write rgba, black and green PNGs.

``rgba`` is Cycles' exact-alpha render (transparent film). ``black`` and ``green`` are composited over it
in 8-bit straight alpha (rgb*a + C*(1-a)), or, with ``render.render_backgrounds``, rendered by Cycles with
the world showing that colour to camera rays only (pixels the object does not cover are set exactly).
With ``render.shadow`` one more render per camera gives ``shadow``, the part's shadow on the ground
(:mod:`deformsim.blender.shadow`), and with ``render.surface`` one more gives ``surface``, the part on a textured
ground rendered whole (:mod:`deformsim.blender.surface`); the images above do not change.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from PIL import Image

from deformsim.atomic import atomic_path
from deformsim.blender import cameras as cams
from deformsim.blender import dense, drop, materials, shadow, surface
from deformsim.blender.lights import set_lights
from deformsim.blender.pose import set_pose
from deformsim.blender.rig import Rig
from deformsim.blender.world import World
from deformsim.config import Config
from deformsim.dataset.layout import SHADOW_KIND, Layout, image_id
from deformsim.sampling import SampleParams
from deformsim.spec.model import Spec

BACKGROUNDS = {"black": (0, 0, 0), "green": (0, 255, 0)}  # sRGB 8-bit; linear green (0, 1, 0) is the same


@dataclass
class RenderContext:
    """Everything the worker built once and reuses for every sample."""

    cfg: Config
    spec: Spec
    scene: object
    obj: object
    rig: Rig
    world: World
    cameras: list
    pivot: object  # tilts object and lattice together (see blender.pose)
    target: tuple[float, float, float]  # bounding-box centre the cameras aim at
    camera_scale: float = 1.0
    ground: float = 0.0  # z the part stands on at rest (pose.mode drop: the ground it falls onto)
    rest: drop.DropResult | None = None  # pose.mode drop: how the last sample came to rest
    catcher: object = None  # render.shadow: the shadow-catcher ground plane (blender.shadow), built on first use
    ground_plane: object = None  # render.surface: the textured ground plane (blender.surface), built on first use


def over_color(rgba: np.ndarray, color: tuple[int, int, int]) -> np.ndarray:
    """Straight-alpha RGBA (uint8) over a flat colour, rounded to nearest: an RGB uint8 image."""
    a = rgba[..., 3:4].astype(np.uint32)
    rgb = rgba[..., :3].astype(np.uint32)
    c = np.asarray(color, dtype=np.uint32)
    return ((rgb * a + c * (255 - a) + 127) // 255).astype(np.uint8)


def _save(path, array: np.ndarray) -> None:
    with atomic_path(path) as tmp:
        Image.fromarray(array).save(tmp, format="PNG")


def _render_to_array(scene, target: Path) -> tuple[np.ndarray, float]:
    """Render the scene's camera into a temporary PNG beside ``target``; return (uint8 pixels, seconds)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.render.", suffix=".png", dir=target.parent)
    os.close(fd)
    try:
        scene.render.filepath = tmp
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        with Image.open(tmp) as im:
            pixels = np.array(im.convert("RGBA" if scene.render.film_transparent else "RGB"))
    finally:
        Path(tmp).unlink(missing_ok=True)
    return pixels, seconds


def apply_state(ctx: RenderContext, p: SampleParams) -> tuple[float, float, float]:
    """Put the scene in sample ``p``'s state (deformation, pose, openings, surface, lighting); return the point
    the cameras aim at (the rest bounding-box centre, or with ``pose.mode`` drop the resting part's)."""
    ctx.rig.set(p.keys, p.displacement, p.seal, p.tab, p.bank, p.bank_amount)
    target = ctx.target
    if ctx.cfg.pose.mode == "drop":  # after the rig: the deformed shape decides how the part comes to rest
        if len(p.drop_rotation) != 4:
            raise ValueError(f"sample {p.index} has no drop_rotation (drawn with pose.mode tilt?)")
        pose = ctx.cfg.pose
        ctx.rest = drop.drop(ctx.scene, ctx.obj, ctx.pivot, ctx.target, ctx.ground, p.drop_rotation,
                             pose.drop_height, pose.drop_frames)
        target = ctx.rest.target
    else:
        ctx.pivot.location = ctx.target
        set_pose(ctx.pivot, p.pose_tilt, p.pose_axis)
    if p.design is not None:
        materials.set_label(p.design)
    if p.material is not None:
        materials.apply_material(ctx.obj, ctx.spec.material, p.material)
    ctx.world.set(p.hdri, p.hdri_rotation, p.hdri_strength)
    set_lights(ctx.scene, p.lights, target, ctx.camera_scale)
    return target


def render_sample(ctx: RenderContext, p: SampleParams, layout: Layout) -> tuple[list[float], list[dict] | None]:
    """Render every camera of sample ``p``; return Cycles' render seconds per camera and, with ``render.dense``,
    each image's dense manifest columns (the maps are written beside the images)."""
    if len(p.cameras) != len(ctx.cameras):
        raise ValueError(f"sample {p.index} has {len(p.cameras)} cameras, the scene {len(ctx.cameras)}")
    target = apply_state(ctx, p)
    scene = ctx.scene
    seconds, rows, alphas = [], None, []
    if ctx.cfg.render.dense:
        sample_cols = {"max_disp_mm": dense.prepare(scene, ctx.obj, ctx.spec, p), **dense.family_flags(ctx.spec, p)}
        rows = []
    if ctx.cfg.render.shadow:
        if ctx.catcher is None:
            ctx.catcher = shadow.make_catcher(scene, ctx.camera_scale)
        shadow.place(ctx.catcher, ctx.obj, target)
    if ctx.cfg.render.surface is not None:
        if p.surface is None:
            raise ValueError(f"sample {p.index} has no surface (drawn without render.surface?)")
        if ctx.ground_plane is None:
            ctx.ground_plane = surface.make_surface(scene, ctx.camera_scale)
        surface.set_surface(ctx.ground_plane, ctx.obj, target, p.surface, ctx.camera_scale)
    for c, (cam, cp) in enumerate(zip(ctx.cameras, p.cameras)):
        cams.place(cam, cp, target, ctx.camera_scale, ctx.obj)
        scene.camera = cam
        iid = image_id(p.index, c)
        rgba, t = _render_to_array(scene, layout.image("rgba", iid))
        _save(layout.image("rgba", iid), rgba)
        if rows is not None:
            threshold = ctx.cfg.render.region_threshold_mm
            rows.append({**sample_cols, **dense.write_maps(scene, cam, rgba[..., 3], layout, iid, threshold)})
        if ctx.cfg.render.shadow:
            alphas.append(rgba[..., 3])
        for kind, color in BACKGROUNDS.items():
            if ctx.cfg.render.render_backgrounds:
                img, dt = _render_background(ctx, layout.image(kind, iid), color)
                img[rgba[..., 3] == 0] = color  # the denoiser can tint flat corners; uncovered pixels are exact
                t += dt
            else:
                img = over_color(rgba, color)
            _save(layout.image(kind, iid), img)
        seconds.append(t)
    # after every other image of the sample: the last of these passes resets the Cycles session (blender.shadow)
    passes = ctx.cfg.render.scene_kinds
    for kind in passes:
        for c, (cam, cp) in enumerate(zip(ctx.cameras, p.cameras)):
            cams.place(cam, cp, target, ctx.camera_scale, ctx.obj)
            scene.camera = cam
            path = layout.image(kind, image_id(p.index, c))
            last = kind == passes[-1] and c == len(ctx.cameras) - 1
            if kind == SHADOW_KIND:
                alpha, dt = shadow.render_alpha(scene, ctx.catcher, ctx.obj, _render_to_array, path, last=last)
                _save(path, shadow.shadow_map(alpha, alphas[c]))
            else:
                rgb, dt = surface.render_scene(scene, ctx.ground_plane, ctx.world, _render_to_array, path, last=last)
                _save(path, rgb)
            seconds[c] += dt
    return seconds, rows


def _render_background(ctx: RenderContext, target: Path, color: tuple[int, int, int]) -> tuple[np.ndarray, float]:
    scene = ctx.scene
    ctx.world.set_camera_color(tuple(v / 255 for v in color))  # 0 and 255 only: sRGB = linear
    scene.render.film_transparent = False
    try:
        return _render_to_array(scene, target)
    finally:
        scene.render.film_transparent = True
