"""The part's drawn shape as one continuous map of space (pure numpy, no Blender).

:func:`shape_points` moves points of the part at rest (or of any of its shape keys: openings, crinkle, simulated
bank entries) to the drawn shape (:class:`~deformsim.sampling.ShapeParams`). Because it is one continuous map of
space, a deformed surface maps to a deformed surface: a crushed can's bank entry becomes the same crush of a tall
or slim can, scaled like its regions (wall, neck, dome).

The built-in can (:mod:`deformsim.blender.part.can`, standing on z = 0 around the z axis) is mapped region by region:
the bottom (dome and standing ring, below the wall) scales with the body's radius times ``dome``, the wall stretches
to make the height, and the top (neck, rim, lid, tab) scales with the rim's radius times ``neck``; radially the body
scales to the diameter and the neck narrows from the body to the rim. Sizes are ratios to standard355's nominal
66.2 x 122.2 mm, so standard355 is the can as built (66.0 x 122.0 mm) and every size is within 0.3 % of its nominal
dimensions. Then any part takes the per-axis scale, taper and bulge about its vertical axis.
"""

from __future__ import annotations

import numpy as np

from deformsim.sampling import ShapeParams

# The built-in can at rest (metres; blender.part.can builds it): body radius, side-wall z range, neck end, top.
BODY_R = 0.033
WALL = (0.010, 0.108)
NECK_START_Z = 0.1096  # first ring of the neck above the wall
NECK_IN_R = 0.0286  # the neck's narrowest radius, under the rim's bead
TOP = 0.122
RIM_RATIO = 0.8773  # rim radius over body radius as built (CAN_SIZES' standard "rim")
NOMINAL = (66.2, 122.2)  # mm: standard355's nominal diameter and height, the size the can is built at


def can_scales(shape: ShapeParams) -> dict[str, float]:
    """The can's region scales for ``shape``: body radius ``r``, rim ``rim``, bottom and top heights, wall stretch.
    A shape whose bottom and top leave no wall raises ValueError."""
    r = shape.diameter / NOMINAL[0]
    rim = r * shape.rim / RIM_RATIO
    bottom = WALL[0] * r * shape.dome
    top = (TOP - WALL[1]) * rim * shape.neck
    height = shape.height / NOMINAL[1] * TOP
    wall = height - bottom - top
    if wall <= 0.1 * (WALL[1] - WALL[0]) * r:
        raise ValueError(f"can shape {shape.size}: {shape.height:g} mm is too short for its dome and neck")
    return {"r": r, "rim": rim, "bottom": bottom, "top": top, "height": height, "wall": wall / (WALL[1] - WALL[0])}


def wall_aspect(shape: ShapeParams) -> float:
    """How much taller, relative to its circumference, the drawn can's label is than the built can's (1 = same)."""
    s = can_scales(shape)
    return s["wall"] * shape.scale[2] / (s["r"] * (shape.scale[0] + shape.scale[1]) / 2)


def _can(co: np.ndarray, shape: ShapeParams) -> np.ndarray:
    s = can_scales(shape)
    x, y, z = co[:, 0], co[:, 1], co[:, 2]
    top_z0 = s["bottom"] + s["wall"] * (WALL[1] - WALL[0])
    z_new = np.where(z < WALL[0], z * s["r"] * shape.dome,
                     np.where(z < WALL[1], s["bottom"] + (z - WALL[0]) * s["wall"],
                              top_z0 + (z - WALL[1]) * s["rim"] * shape.neck))
    r = np.hypot(x, y)
    w = np.clip((r - NECK_IN_R) / (BODY_R - NECK_IN_R), 0, 1)
    top_r = r * s["rim"] + (s["r"] - s["rim"]) * BODY_R * w  # neck: from the body's radius in to the rim's
    m = np.clip((z - WALL[1]) / (NECK_START_Z - WALL[1]), 0, 1)
    m = m * m * (3 - 2 * m)  # continuous in z for points off the rest surface (deformed keys)
    r_new = (1 - m) * r * s["r"] + m * top_r
    factor = np.where(r > 1e-9, r_new / np.maximum(r, 1e-9), (1 - m) * s["r"] + m * s["rim"])
    return np.column_stack([x * factor, y * factor, z_new])


def _variation(co: np.ndarray, shape: ShapeParams, height: float) -> np.ndarray:
    sx, sy, sz = shape.scale
    h = co[:, 2] / height
    radial = np.maximum(1 + shape.taper * (2 * h - 1), 0.05) * (1 + shape.bulge * np.sin(np.pi * np.clip(h, 0, 1)))
    return np.column_stack([co[:, 0] * sx * radial, co[:, 1] * sy * radial, co[:, 2] * sz])


def shape_points(co: np.ndarray, shape: ShapeParams, height: float, can: bool) -> np.ndarray:
    """``co`` (N x 3, the part's object space: centred on the z axis, standing on z = 0) in the drawn ``shape``:
    the can's size map when ``can``, then scale, taper and bulge over the part's rest ``height`` (metres)."""
    co = np.asarray(co, dtype=np.float64)
    if can:
        height = can_scales(shape)["height"]
        co = _can(co, shape)
    return _variation(co, shape, height)
