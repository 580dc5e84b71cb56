"""The part's shape per sample (``object.shapes``): every shape key through one map of space, the rig refitted.

:class:`Shaper` keeps the part's key blocks as built (Basis, the openings, crinkle and the simulated bank's
entries) and, per sample, writes each through :func:`~deformsim.blender.part.shape_map.shape_points`; the lattice
is refitted to the shaped part's bounds (its keys are in lattice space, so every lattice key deforms the shaped part
as it does the built one), and the pivot's children are re-parented about the shaped part's centre, so poses, drops,
cameras and the ground planes work on it as on a part built that way.
"""

from __future__ import annotations

import numpy as np
from mathutils import Matrix

from deformsim.blender.part.shape_map import shape_points, wall_aspect
from deformsim.sampling import ShapeParams


def _get(seq) -> np.ndarray:
    flat = np.empty(len(seq) * 3, np.float32)
    seq.foreach_get("co", flat)
    return flat.reshape(-1, 3).astype(np.float64)


class Shaper:
    """Puts the part (``obj``, rigged with ``lattice`` under ``pivot``) in a drawn shape; ``can``: the built-in can."""

    def __init__(self, obj, lattice, pivot, margin: float, can: bool):
        self.obj, self.lattice, self.pivot, self.margin, self.can = obj, lattice, pivot, margin, can
        keys = obj.data.shape_keys
        self.rest = {b.name: _get(b.data) for b in keys.key_blocks} if keys else {}
        self.vertices = _get(obj.data.vertices)
        self.height = float(self.vertices[:, 2].max())
        self.label_aspect = 1.0  # the label's height over its width, relative to the built can's

    def apply(self, shape: ShapeParams) -> tuple[tuple[float, float, float], float]:
        """Shape the part as ``shape``; return its rest bounding-box centre (where cameras aim) and its lowest z."""
        mesh = self.obj.data
        for name, co in self.rest.items():
            mesh.shape_keys.key_blocks[name].data.foreach_set("co", self._map(co, shape).astype(np.float32).ravel())
        verts = self._map(self.vertices, shape)
        mesh.vertices.foreach_set("co", verts.astype(np.float32).ravel())
        mesh.update()
        lo, hi = verts.min(0), verts.max(0)
        centre = (lo + hi) / 2
        self.lattice.location = tuple(centre)
        self.lattice.scale = tuple(np.maximum(hi - lo, 1e-6) * (1 + 2 * self.margin))
        inverse = Matrix.Translation(tuple(-centre))
        for child in (self.obj, self.lattice):
            child.matrix_parent_inverse = inverse
        self.pivot.location = tuple(centre)
        self.label_aspect = wall_aspect(shape) if self.can else 1.0
        return tuple(float(v) for v in centre), float(lo[2])

    def _map(self, co: np.ndarray, shape: ShapeParams) -> np.ndarray:
        return shape_points(co, shape, self.height, self.can)
