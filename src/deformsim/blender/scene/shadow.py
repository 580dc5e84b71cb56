"""The part's shadow on the ground (``render.shadow``), for compositing: a Cycles shadow catcher, rendered apart.

A large plane (:data:`CATCHER`, see :mod:`deformsim.blender.scene.ground`) is put under the part for each sample,
at the lowest point of the posed, deformed mesh, and marked as a Cycles shadow catcher. It stays hidden for the
ordinary renders, so ``rgba`` (and every variant made from it) is byte-identical to a render without shadows. After
the sample's images, one more render per camera shows the plane with the part as a holdout: with the transparent
film Cycles writes RGB ~0 and alpha = the shadow's strength on the catcher (the world's light, mostly from its
brightest direction, and the area lights make its shape; the part's occlusion of the sky near the contact makes the
dark contact line), and alpha 0 where the holdout part covers. The map saved is that alpha divided by the part's
uncovered fraction (1 - part alpha of the ``rgba`` render): the shadow on the ground *behind* each pixel, so the
composite can darken the background by it before laying the part over; 0 where the part covers the pixel fully, and
with the noise floor :data:`FLOOR` taken off, so it is exactly 0 far from the part.

The plane is seen from above only (cameras with polar angle < 90 degrees): from below it would hide the part.
"""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from deformsim.blender.cycles import render_to_array
from deformsim.blender.feature import Feature, RenderContext
from deformsim.blender.scene.ground import make_plane, place, plane_shown
from deformsim.dataset.layout import Layout

CATCHER = "DeformsimShadowCatcher"
FLOOR = 12 / 255  # shadow opacity below this is sampling noise of the catcher (measured up to ~8/255 at 16 spp)


def make_catcher(scene, camera_scale: float = 1.0):
    """The hidden shadow-catcher plane (grey diffuse), linked to ``scene``; built once per worker."""
    obj = make_plane(scene, CATCHER, camera_scale)
    mat = bpy.data.materials.new(CATCHER)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
        bsdf.inputs["Roughness"].default_value = 1.0
    obj.data.materials.append(mat)
    obj.is_shadow_catcher = True
    return obj


def render_alpha(scene, catcher, obj, target: Path, last: bool = True) -> tuple[np.ndarray, float]:
    """Render the shadow pass of the scene's camera (plane shown, part held out); return (alpha uint8, seconds);
    ``last``: see :func:`deformsim.blender.scene.ground.plane_shown`."""
    obj.is_holdout = True
    try:
        with plane_shown(scene, catcher, last):
            pixels, seconds = render_to_array(scene, target)
    finally:
        obj.is_holdout = False
    return pixels[..., 3], seconds


def shadow_map(shadow_alpha: np.ndarray, part_alpha: np.ndarray, floor: float = FLOOR) -> np.ndarray:
    """The 8-bit shadow map from the shadow pass's alpha and the part's alpha (both uint8): the shadow behind
    each pixel, 0 where the part covers fully, the noise floor taken off and the rest stretched back to 0..1."""
    s = shadow_alpha.astype(np.float64)
    uncovered = 255.0 - part_alpha.astype(np.float64)
    behind = np.divide(s, uncovered, out=np.zeros_like(s), where=uncovered > 0)
    behind = np.clip((behind - floor) / (1.0 - floor), 0.0, 1.0)
    return np.rint(behind * 255).astype(np.uint8)


class Shadow(Feature):
    """``render.shadow``: ``images/shadow/ID.png`` per camera."""

    def __init__(self, ctx: RenderContext):
        super().__init__(ctx)
        self.catcher = make_catcher(ctx.scene, ctx.camera_scale)
        self.alphas: list[np.ndarray] = []  # the sample's rgba alpha per camera

    def apply(self, p, target) -> None:
        place(self.catcher, self.ctx.obj, target)
        self.alphas = []

    def image(self, c: int, iid: str, rgba: np.ndarray, layout: Layout) -> None:
        self.alphas.append(rgba[..., 3])

    def render_pass(self, c: int, path: Path, last: bool) -> tuple[np.ndarray, float]:
        alpha, seconds = render_alpha(self.ctx.scene, self.catcher, self.ctx.obj, path, last=last)
        return shadow_map(alpha, self.alphas[c]), seconds
