"""Render one sample: set the shape, rig, pose, label or material, world and cameras; write rgba, black and green PNGs.

``rgba`` is Cycles' exact-alpha render (transparent film). ``black`` and ``green`` are composited over it
in 8-bit straight alpha (rgb*a + C*(1-a)), or, with ``render.render_backgrounds``, rendered by Cycles with
the world showing that colour to camera rays only (pixels the object does not cover are set exactly).
The optional features (:mod:`deformsim.blender.features`) add their state, images and manifest columns; those
with an extra pass (shadow, surface) render it after every other image of the sample, and the images above
do not change.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import numpy as np
from PIL import Image

from deformsim.atomic import atomic_path
from deformsim.blender.cycles import render_to_array
from deformsim.blender.feature import RenderContext
from deformsim.blender.motion.pose import set_pose
from deformsim.blender.part import materials
from deformsim.blender.scene import cameras as cams
from deformsim.dataset.layout import Layout, image_id
from deformsim.dataset.rendered import Rendered
from deformsim.sampling import SampleParams

BACKGROUNDS = {"black": (0, 0, 0), "green": (0, 255, 0)}  # sRGB 8-bit; linear green (0, 1, 0) is the same


def over_color(rgba: np.ndarray, color: tuple[int, int, int]) -> np.ndarray:
    """Straight-alpha RGBA (uint8) over a flat colour, rounded to nearest: an RGB uint8 image."""
    a = rgba[..., 3:4].astype(np.uint32)
    rgb = rgba[..., :3].astype(np.uint32)
    c = np.asarray(color, dtype=np.uint32)
    return ((rgb * a + c * (255 - a) + 127) // 255).astype(np.uint8)


def _save(path, array: np.ndarray) -> None:
    with atomic_path(path) as tmp:
        Image.fromarray(array).save(tmp, format="PNG")


def apply_state(ctx: RenderContext, p: SampleParams) -> tuple[float, float, float]:
    """Put the scene in sample ``p``'s state (deformation, pose, openings, materials, lighting and every active
    feature's); return the point the cameras aim at (the rest bounding-box centre, or where a feature placed the
    part: with ``pose.mode`` drop the resting part's)."""
    if p.shape is not None:  # first: the rig, the pose and every feature work on the shaped part
        if ctx.shaper is None:
            raise ValueError(f"sample {p.index} has a shape, the worker's config no object.shapes")
        ctx.target, ctx.ground = ctx.shaper.apply(p.shape)
    ctx.rig.set(p.keys, p.displacement, p.seal, p.tab, p.bank, p.bank_amount)
    # after the rig: a dropped part's deformed shape decides how it comes to rest
    placed = [t for f in ctx.features if (t := f.place(p)) is not None]
    if placed:
        target = placed[0]
    else:
        target = ctx.target
        ctx.pivot.location = ctx.target
        set_pose(ctx.pivot, p.pose_tilt, p.pose_axis)
    if p.design is not None:
        aspect = ctx.shaper.label_aspect if ctx.shaper is not None else 1.0
        materials.set_label(p.design, look=p.appearance, aspect=aspect)
    if p.material is not None:
        materials.apply_material(ctx.obj, ctx.spec.material, p.material, p.appearance)
    ctx.world.set(p.hdri, p.hdri_rotation, p.hdri_strength)
    for f in ctx.features:
        f.apply(p, target)
    return target


def render_sample(ctx: RenderContext, p: SampleParams, layout: Layout) -> Rendered:
    """Render every camera of sample ``p`` into ``layout``; return what the worker reports: Cycles' render seconds
    per camera, the features' image kinds and manifest columns."""
    if len(p.cameras) != len(ctx.cameras):
        raise ValueError(f"sample {p.index} has {len(p.cameras)} cameras, the scene {len(ctx.cameras)}")
    target = apply_state(ctx, p)
    scene = ctx.scene
    seconds = []
    with _alpha_only(scene, ctx.cfg.render.part_alpha_only):
        for c, (cam, cp) in enumerate(zip(ctx.cameras, p.cameras)):
            seconds.append(_render_part(ctx, c, cam, cp, target, image_id(p.index, c), layout))
    # after every other image of the sample: the last of these passes resets the Cycles session (blender.scene.ground)
    passes = [f for f in ctx.features if f.extra_pass]
    for f in passes:
        for c, (cam, cp) in enumerate(zip(ctx.cameras, p.cameras)):
            cams.place(cam, cp, target, ctx.camera_scale, ctx.obj)
            scene.camera = cam
            (kind,) = f.kinds
            path = layout.image(kind, image_id(p.index, c))
            img, dt = f.render_pass(c, path, last=f is passes[-1] and c == len(ctx.cameras) - 1)
            _save(path, img)
            seconds[c] += dt
    return Rendered(
        index=p.index,
        render_seconds=seconds,
        kinds=tuple(kind for f in ctx.features for kind in f.kinds),
        sample_columns={k: v for f in ctx.features for k, v in f.sample_columns().items()},
        image_columns=[_image_columns(ctx, layout, image_id(p.index, c), c) for c in range(len(ctx.cameras))],
    )


def _render_part(ctx: RenderContext, c: int, cam, cp, target, iid: str, layout: Layout) -> float:
    """Render camera ``c``'s image of the part (rgba, the features' images from it, black and green); its seconds."""
    scene = ctx.scene
    cams.place(cam, cp, target, ctx.camera_scale, ctx.obj)
    scene.camera = cam
    rgba, t = render_to_array(scene, layout.image("rgba", iid))
    _save(layout.image("rgba", iid), rgba)
    for f in ctx.features:
        f.image(c, iid, rgba, layout)
    for kind, color in BACKGROUNDS.items():
        if ctx.cfg.render.render_backgrounds:
            img, dt = _render_background(ctx, layout.image(kind, iid), color)
            img[rgba[..., 3] == 0] = color  # the denoiser can tint flat corners; uncovered pixels are exact
            t += dt
        else:
            img = over_color(rgba, color)
        _save(layout.image(kind, iid), img)
    return t


@contextmanager
def _alpha_only(scene, on: bool):
    """With ``on`` (``render.surface.part_colour: false``), the renders inside trace no bounce and skip the
    denoiser: the camera rays, and with them the alpha and every dense pass, are those of the full render (Cycles
    draws a pixel's camera samples from the same seed whatever the bounces); only the colour is cruder."""
    cy = scene.cycles
    saved = (cy.max_bounces, cy.use_denoising)
    if on:
        cy.max_bounces, cy.use_denoising = 0, False
    try:
        yield
    finally:
        cy.max_bounces, cy.use_denoising = saved


def _image_columns(ctx: RenderContext, layout: Layout, iid: str, c: int) -> dict:
    """Camera ``c``'s manifest columns from the features: each one's image paths, then its columns."""
    row = {}
    for f in ctx.features:
        row.update({kind: layout.rel(layout.image(kind, iid)) for kind in f.kinds}, **f.image_columns(c))
    return row


def _render_background(ctx: RenderContext, target: Path, color: tuple[int, int, int]) -> tuple[np.ndarray, float]:
    scene = ctx.scene
    ctx.world.set_camera_color(tuple(v / 255 for v in color))  # 0 and 255 only: sRGB = linear
    scene.render.film_transparent = False
    try:
        return render_to_array(scene, target)
    finally:
        scene.render.film_transparent = True
