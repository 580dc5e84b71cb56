"""The part's shadow on the ground (``render.shadow``), for compositing: a Cycles shadow catcher, rendered apart.

A large plane (:data:`CATCHER`) is put under the part for each sample, at the lowest point of the posed, deformed
mesh, and marked as a Cycles shadow catcher. It stays hidden for the ordinary renders, so ``rgba`` (and every
variant made from it) is byte-identical to a render without shadows. After the sample's images, one more render
per camera shows the plane with the part as a holdout: with the transparent film Cycles writes RGB ~0 and alpha = the
shadow's strength on the catcher (the world's light, mostly from its brightest direction, and the area lights
make its shape; the part's occlusion of the sky near the contact makes the dark contact line), and alpha 0 where
the holdout part covers. The map saved is that alpha divided by the part's uncovered fraction (1 - part alpha of
the ``rgba`` render): the shadow on the ground *behind* each pixel, so the composite can darken the background
by it before laying the part over; 0 where the part covers the pixel fully, and with the noise floor
:data:`FLOOR` taken off, so it is exactly 0 far from the part.

The plane is seen from above only (cameras with polar angle < 90 degrees): from below it would hide the part.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import bpy
import numpy as np

from deformsim.blender.cameras import world_vertices

CATCHER = "DeformsimShadowCatcher"
PLANE_SIZE = 40.0  # m per unit of camera scale: far past the frame at every camera radius and lens
FLOOR = 12 / 255  # shadow opacity below this is sampling noise of the catcher (measured up to ~8/255 at 16 spp)


def make_plane(scene, name: str, camera_scale: float = 1.0):
    """A hidden square ground plane named ``name``, :data:`PLANE_SIZE` times ``camera_scale`` across, linked to
    ``scene`` (the shadow catcher and the rendered surface, :mod:`deformsim.blender.surface`)."""
    mesh = bpy.data.meshes.new(name)
    half = PLANE_SIZE * camera_scale / 2
    mesh.from_pydata([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], [], [(0, 1, 2, 3)])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    obj.hide_render = True
    return obj


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


def lowest_point(obj) -> float:
    """World z of the lowest vertex of ``obj`` as evaluated now (shape keys, lattice, pose)."""
    return float(world_vertices(obj)[:, 2].min())


def place(catcher, obj, target: tuple[float, float, float]) -> None:
    """Put the plane under the part's current lowest point, centred below the cameras' target."""
    catcher.location = (target[0], target[1], lowest_point(obj))


@contextmanager
def plane_shown(scene, plane, last: bool):
    """``plane`` shown for one extra render pass after the sample's own images, hidden again afterwards.

    ``last``: the sample's last extra pass. A Cycles session that has rendered a shadow catcher keeps rendering
    the part's edges differently (some alpha and colour of edge pixels change, even with the catcher hidden or
    removed), so the last pass runs without persistent data: the session is freed and the next ordinary render
    starts a fresh one, byte-identical to a render without the pass."""
    render = scene.render
    plane.hide_render = False
    render.use_persistent_data = not last
    try:
        yield
    finally:
        plane.hide_render = True
        render.use_persistent_data = True


def render_alpha(scene, catcher, obj, render_to_array, target: Path, last: bool = True) -> tuple[np.ndarray, float]:
    """Render the shadow pass of the scene's camera (plane shown, part held out); return (alpha uint8, seconds);
    ``last``: see :func:`plane_shown`."""
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
