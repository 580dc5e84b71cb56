"""Parametric lattice-point operations and vertex-selection rules: pure NumPy, no Blender.

Lattice points live in normalised lattice space, each coordinate in [-0.5, 0.5]; ``z`` is up and the
height fraction is ``t = z + 0.5``. An operation maps an (N, 3) array of points to a new one; a key is the
composition of its operations applied to the rest lattice. The Blender side writes the result into a
lattice shape key, so what a key does can be tested and previewed without rendering.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from deformsim.schema import MAX_SEED, shown

_AXES = {"x": 0, "y": 1, "z": 2}
_CHOICES = {"axis": ("x", "y"), "anchor": ("bottom", "top", "center")}
# every number a parameter takes: heights are fractions, sizes and amounts fractions of the lattice, angles degrees
_BOUNDS = {"at": (0, 1), "amount": (0, 10), "width": (0, 10), "radius": (0, 10), "depth": (0, 10),
           "bulge": (-10, 10), "expand": (-10, 10), "kink": (-10, 10), "inward": (-10, 10),
           "angle": (-720, 720), "azimuth": (-720, 720), "seed": (0, MAX_SEED)}


@dataclass(frozen=True)
class Op:
    fn: Callable[..., np.ndarray]

    @property
    def defaults(self) -> dict:
        sig = inspect.signature(self.fn)
        return {k: p.default for k, p in list(sig.parameters.items())[1:]}

    def check(self, params: dict) -> None:
        """Raise ValueError on unknown parameters or out-of-range values."""
        unknown = set(params) - set(self.defaults)
        if unknown:
            raise ValueError(f"unknown parameter(s) {shown(sorted(map(str, unknown)))} (allowed: {sorted(self.defaults)})")
        merged = {**self.defaults, **params}
        for k, v in merged.items():
            if k in _CHOICES and v not in _CHOICES[k]:
                raise ValueError(f"{k} must be {' or '.join(_CHOICES[k])}, got {shown(v)}")
            if k in _CHOICES:
                continue
            lo, hi = _BOUNDS[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or (k == "seed" and not isinstance(v, int)):
                raise ValueError(f"{k}={shown(v)} must be {'an integer' if k == 'seed' else 'a number'}")
            if isinstance(v, float) and not math.isfinite(v):
                raise ValueError(f"{k}={v} must be a finite number")
            if not lo <= v <= hi:
                raise ValueError(f"{k}={shown(v)} " + ("must not be negative" if lo == 0 and v < 0 else
                                                       f"must lie in [{lo}, {hi}]"))
        if "amount" in merged and self.fn is compress and merged["amount"] >= 1:
            raise ValueError(f"amount={merged['amount']} must be < 1 for compress")

    def __call__(self, points: np.ndarray, **params) -> np.ndarray:
        return self.fn(np.asarray(points, dtype=float).copy(), **params)


def _bump(t: np.ndarray, at: float, width: float) -> np.ndarray:
    return np.exp(-(((t - at) / max(width, 1e-6)) ** 2))


def compress(p, amount=0.3, anchor="bottom", bulge=0.1, at=0.5, width=0.3):
    """Axial crush: heights shrink by ``amount`` towards ``anchor``; walls bulge out around ``at``."""
    t = p[:, 2] + 0.5
    ref = {"bottom": 0.0, "top": 1.0, "center": 0.5}[anchor]
    new_t = ref + (t - ref) * (1 - amount)
    radial = 1 + bulge * _bump(t, at, width)
    p[:, 0] *= radial
    p[:, 1] *= radial
    p[:, 2] = new_t - 0.5
    return p


def squeeze(p, axis="x", amount=0.4, at=0.5, width=0.25, expand=0.3):
    """Pinch: squeeze along ``axis`` around height ``at``; the other horizontal axis widens by ``expand``."""
    t = p[:, 2] + 0.5
    b = _bump(t, at, width)
    i = _AXES[axis]
    p[:, i] *= 1 - amount * b
    p[:, 1 - i] *= 1 + expand * amount * b
    return p


def bend(p, axis="x", angle=35.0, at=0.5, kink=0.15, width=0.12):
    """Fold: the part above height ``at`` rotates by ``angle`` degrees towards ``axis``; a kink dents the fold."""
    i = _AXES[axis]
    t = p[:, 2] + 0.5
    s = np.clip((t - at) / max(1 - at, 1e-6), 0, 1)  # 0 below the fold, 1 at the top
    a = np.radians(angle) * np.minimum(1.0, s * 4)
    z0 = at - 0.5
    dz, dx = p[:, 2] - z0, p[:, i]
    above = t > at
    p[above, i] = (dx * np.cos(a) + dz * np.sin(a))[above]
    p[above, 2] = (z0 - dx * np.sin(a) + dz * np.cos(a))[above]
    # the material buckles inward on the compressed side of the fold line
    side = np.sign(angle) * np.sign(dx)
    p[:, i] -= kink * _bump(t, at, width) * np.clip(side, 0, None) * np.abs(dx) * 2
    return p


def twist(p, angle=40.0, anchor="bottom"):
    """Twist: rotation about the up axis growing linearly with height (``angle`` degrees at the far end)."""
    t = p[:, 2] + 0.5
    frac = t if anchor == "bottom" else (1 - t) if anchor == "top" else t - 0.5
    a = np.radians(angle) * frac
    x, y = p[:, 0].copy(), p[:, 1].copy()
    p[:, 0] = x * np.cos(a) - y * np.sin(a)
    p[:, 1] = x * np.sin(a) + y * np.cos(a)
    return p


def crumple(p, amount=0.12, seed=0, inward=0.6, at=0.5, width=1.0):
    """Crunch: seeded random local displacement of lattice points, biased inward, weighted around ``at``."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(size=p.shape)
    r = np.linalg.norm(p[:, :2], axis=1, keepdims=True)
    radial = np.where(r > 1e-9, p[:, :2] / np.maximum(r, 1e-9), 0)
    t = p[:, 2] + 0.5
    w = amount * _bump(t, at, width)[:, None]
    p[:, :2] += w * (noise[:, :2] * (1 - inward) - radial * inward * np.abs(noise[:, :1]))
    p[:, 2:] += w * noise[:, 2:] * 0.5
    return p


def dent(p, azimuth=0.0, at=0.5, radius=0.3, depth=0.3):
    """A local dent: points near (azimuth, height) are pushed towards the axis."""
    a = np.radians(azimuth)
    centre = np.array([0.5 * np.cos(a), 0.5 * np.sin(a), at - 0.5])
    d = np.linalg.norm(p - centre, axis=1)
    w = depth * np.exp(-((d / max(radius, 1e-6)) ** 2))
    p[:, 0] -= w * np.cos(a) * 0.5
    p[:, 1] -= w * np.sin(a) * 0.5
    return p


OPERATIONS: dict[str, Op] = {f.__name__: Op(f) for f in (compress, squeeze, bend, twist, crumple, dent)}


def rest_lattice(points: tuple[int, int, int]) -> np.ndarray:
    """Rest positions of a lattice in Blender's point order (u fastest, then v, then w)."""
    u, v, w = (np.linspace(-0.5, 0.5, n) for n in points)
    ww, vv, uu = np.meshgrid(w, v, u, indexing="ij")
    return np.stack([uu.ravel(), vv.ravel(), ww.ravel()], axis=1)


def key_points(rest: np.ndarray, ops: list[tuple[str, dict]]) -> np.ndarray:
    """Apply a key's operations, in order, to the rest lattice."""
    p = np.asarray(rest, dtype=float)
    for name, params in ops:
        p = OPERATIONS[name](p, **params)
    return p


def select_vertices(
    co: np.ndarray,
    normals: np.ndarray,
    *,
    in_group: np.ndarray | None = None,
    max_normal_angle: float | None = None,
    min_normal_angle: float | None = None,
    height_band: tuple[float, float] | None = None,
) -> np.ndarray:
    """Boolean mask of vertices meeting every given criterion (see :class:`spec.SelectionRule`)."""
    mask = np.ones(len(co), dtype=bool)
    if in_group is not None:
        mask &= in_group
    if max_normal_angle is not None or min_normal_angle is not None:
        n = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        angle = np.degrees(np.arcsin(np.clip(np.abs(n[:, 2]), 0, 1)))  # from horizontal
        if max_normal_angle is not None:
            mask &= angle <= max_normal_angle
        if min_normal_angle is not None:
            mask &= angle >= min_normal_angle
    if height_band is not None:
        z = co[:, 2]
        lo, hi = z.min(), z.max()
        t = (z - lo) / max(hi - lo, 1e-12)
        mask &= (t >= height_band[0]) & (t <= height_band[1])
    return mask
