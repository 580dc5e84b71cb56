"""A hidden ground plane under the part, shown for one extra render per camera (the shadow catcher of
:mod:`deformsim.blender.scene.shadow`, the textured ground of :mod:`deformsim.blender.scene.surface`)."""

from __future__ import annotations

from contextlib import contextmanager

import bpy

from deformsim.blender.scene.cameras import world_vertices

PLANE_SIZE = 40.0  # m per unit of camera scale: far past the frame at every camera radius and lens


def make_plane(scene, name: str, camera_scale: float = 1.0):
    """A hidden square ground plane named ``name``, :data:`PLANE_SIZE` times ``camera_scale`` across, linked to
    ``scene``."""
    mesh = bpy.data.meshes.new(name)
    half = PLANE_SIZE * camera_scale / 2
    mesh.from_pydata([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], [], [(0, 1, 2, 3)])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    obj.hide_render = True
    return obj


def lowest_point(obj) -> float:
    """World z of the lowest vertex of ``obj`` as evaluated now (shape keys, lattice, pose)."""
    return float(world_vertices(obj)[:, 2].min())


def place(plane, obj, target: tuple[float, float, float]) -> None:
    """Put the plane under the part's current lowest point, centred below the cameras' target."""
    plane.location = (target[0], target[1], lowest_point(obj))


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
