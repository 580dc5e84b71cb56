"""The vertices or faces of a mesh that a spec's :class:`~deformsim.spec.model.SelectionRule` selects."""

from __future__ import annotations

import numpy as np

from deformsim.errors import UserError
from deformsim.spec.lattice_ops import select_vertices
from deformsim.spec.model import SelectionRule


def vectors(seq, attr: str) -> np.ndarray:
    """An (n, 3) float array of the 3-vector ``attr`` of every element of a bpy collection."""
    flat = np.empty(len(seq) * 3, dtype=np.float32)
    seq.foreach_get(attr, flat)
    return flat.reshape(-1, 3).astype(float)


def selected(obj, rule: SelectionRule, what: str, faces: bool = False) -> np.ndarray:
    """Mask of ``obj``'s vertices meeting ``rule``, or with ``faces`` of its faces (by centre and normal; in a group
    when all their vertices are). ``what`` names the rule in the error raised when it selects nothing."""
    mesh = obj.data
    in_group = None
    if rule.group is not None:
        group = obj.vertex_groups.get(rule.group)
        if group is None:
            raise UserError(f"{what}: vertex group '{rule.group}' not found on the mesh")
        in_group = np.array([any(g.group == group.index and g.weight > 0 for g in v.groups) for v in mesh.vertices])
    elements = mesh.polygons if faces else mesh.vertices
    if faces and in_group is not None:
        in_group = np.array([in_group[list(p.vertices)].all() for p in mesh.polygons], dtype=bool)
    mask = select_vertices(
        vectors(elements, "center" if faces else "co"),
        vectors(elements, "normal"),
        in_group=in_group,
        max_normal_angle=rule.max_normal_angle,
        min_normal_angle=rule.min_normal_angle,
        height_band=rule.height_band,
    )
    if not mask.any():
        raise UserError(f"{what} selects no {'face' if faces else 'vertex'} of the mesh")
    return mask
