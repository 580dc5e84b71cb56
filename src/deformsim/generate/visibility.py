"""Whether a spec's lattice keys show at the render size: how many pixels each moves the part in a typical image.

A key's movement is its lattice points' displacement smoothed as Blender's B-spline lattice smooths it, evaluated
on the part's bounding box, at the weight a key gets in a typical deformed sample (``deform.extent`` shared by the
drawn families, a family's weight by its keys), in pixels of the smallest part a render shows (``camera.fill``'s
low end, else the farthest camera). Pure NumPy: no Blender, nothing rendered.
"""

from __future__ import annotations

import numpy as np

from deformsim.config import REFERENCE_SIZE, Config
from deformsim.sampling import allowed_families
from deformsim.spec.lattice_ops import key_points, rest_lattice
from deformsim.spec.model import Spec

MIN_PIXELS = 1.0  # a key that moves the part less than this in a typical image is reported
SENSOR_MM = 36.0  # Blender's default sensor width (the frame side of a square render)
CAN_SIZE = (0.066, 0.066, 0.122)  # m: the built-in can
FACE_POINTS = 24  # per side of each face of the bounding box where movement is evaluated


def _weights(t: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline weights (N, 4) of the control points i-1..i+2 at fraction ``t`` past point i."""
    return np.stack([(1 - t) ** 3, 3 * t**3 - 6 * t**2 + 4, -3 * t**3 + 3 * t**2 + 3 * t + 1, t**3], 1) / 6


def lattice_displacement(field: np.ndarray, points: tuple[int, int, int], at: np.ndarray) -> np.ndarray:
    """The B-spline lattice's displacement (N, 3) at normalised points ``at`` (N, 3) in [-0.5, 0.5], from the
    control points' displacement ``field`` (in Blender's point order); indices past an edge take the edge's point."""
    grid = field.reshape(points[2], points[1], points[0], 3)  # w, v, u
    idx, wts = [], []
    for axis, n in enumerate(points):
        u = np.clip(at[:, axis] + 0.5, 0, 1) * (n - 1)
        i = np.minimum(np.floor(u).astype(int), n - 1)
        idx.append(np.clip(i[:, None] + np.arange(-1, 3), 0, n - 1))
        wts.append(_weights(u - i))
    out = np.zeros((len(at), 3))
    for a in range(4):
        for b in range(4):
            for c in range(4):
                w = wts[0][:, a] * wts[1][:, b] * wts[2][:, c]
                out += w[:, None] * grid[idx[2][:, c], idx[1][:, b], idx[0][:, a]]
    return out


def box_surface(margin: float, n: int = FACE_POINTS) -> np.ndarray:
    """Points (normalised lattice space) on the faces of the part's bounding box inside a lattice of ``margin``."""
    h = 0.5 / (1 + 2 * margin)
    s = np.linspace(-h, h, n)
    a, b = (g.ravel() for g in np.meshgrid(s, s))
    faces = []
    for axis in range(3):
        for side in (-h, h):
            p = np.zeros((len(a), 3))
            p[:, axis], p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = side, a, b
            faces.append(p)
    return np.concatenate(faces)


def key_movement(spec: Spec, size: tuple[float, float, float]) -> dict[str, float]:
    """Each lattice key's largest movement of the part's bounding box at full weight, in metres."""
    pts = spec.lattice.points
    rest = rest_lattice(pts)
    at = box_surface(spec.lattice.margin)
    scale = np.asarray(size) * (1 + 2 * spec.lattice.margin)  # metres per normalised unit, per axis
    out = {}
    for fam in spec.families:
        for key in fam.keys:
            field = key_points(rest, [(op.op, op.params) for op in key.ops]) - rest
            moved = lattice_displacement(field, pts, at) * scale
            out[key.name] = float(np.linalg.norm(moved, axis=1).max())
    return out


def typical_weights(cfg: Config, spec: Spec) -> dict[str, float]:
    """The weight each key gets in a typical deformed sample that draws its family: the mean ``deform.extent`` over
    the mean number of families drawn, over the keys of its family."""
    allowed = allowed_families(cfg, spec)
    lo, hi = cfg.deform.families
    hi = min(hi, len(allowed))
    families = (min(lo, hi) + hi) / 2
    extent = sum(cfg.deform.extent) / 2
    return {k.name: extent / families / len(spec.families[f].keys) for f in allowed for k in spec.families[f].keys}


def pixels_per_metre(cfg: Config, size: tuple[float, float, float]) -> float:
    """Pixels per metre on the smallest part a render shows: the smallest over the cameras of its longest side at
    the low end of the camera's fill (``camera.fill`` or ``fill_views``), else at the farthest radius and widest lens."""
    res, largest = cfg.render.resolution, max(size)
    cam = cfg.camera
    lens = cam.lens_mm[0] if isinstance(cam.lens_mm, tuple) else cam.lens_mm
    distance = cam.radius[1] * largest / REFERENCE_SIZE
    by_radius = res / (distance * SENSOR_MM / lens)
    return min(res * f[0] / largest if f is not None else by_radius for f in cam.fills)


def invisible_keys(cfg: Config, spec: Spec, size: tuple[float, float, float] | None) -> str | None:
    """One line naming the lattice keys that move the part less than :data:`MIN_PIXELS` in a typical image, or None;
    ``size``: the part's (metres), None for the built-in can."""
    size = tuple(size) if size is not None else CAN_SIZE
    px = pixels_per_metre(cfg, size)
    weights = typical_weights(cfg, spec)
    moved = {k: m * weights[k] * px for k, m in key_movement(spec, size).items() if k in weights}
    small = {k: v for k, v in moved.items() if v < MIN_PIXELS}
    if not small:
        return None
    named = ", ".join(f"'{k}' {v:.1f} px" for k, v in sorted(small.items(), key=lambda kv: kv[1]))
    return (f"{len(small)} of {len(moved)} spec keys move the part less than {MIN_PIXELS:g} px in a typical deformed "
            f"image ({cfg.render.resolution} px renders, the part {max(size) * px:.0f} px across): {named}; too small "
            "to see: deepen them, or raise render.resolution, camera.fill or deform.extent")
