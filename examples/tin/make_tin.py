"""Write a food tin as a CAD export would: a closed, ribbed steel tin of revolution in millimetres (STL).

Beads are rolled into the side wall, the ends are double-seamed (a rim that stands out past the body at the top
and bottom), and each end panel is recessed behind a countersink with concentric expansion rings. The stated
diameter is across the seams, the height from seam to seam (default 73 x 110 mm, a common food-tin size):
    python examples/tin/make_tin.py OUT.stl [--diameter 73] [--height 110] [--beads 14] [--segments 128] [--ends rings]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

SEAM_OVERHANG = 1.0  # mm: the seam's radius past the body's
SEAM_HEIGHT = 3.2  # mm: the seam's height at each end
PLAIN_BAND = 14.0  # mm: plain wall between each seam and the nearest bead
BEAD_DEPTH, BEAD_WIDTH = 0.9, 2.2  # mm: how far a bead is rolled in, and its half-width (a smooth groove)
RECESS, COUNTERSINK = 3.0, 4.2  # mm: the end panel's and the countersink's depth behind the seam's face
RING_HEIGHT = 0.5  # mm: how far the end panels' expansion rings stand proud
# End panels: "rings", two rings spread over the panel; "flat", three rings in its outer third round a flat centre
# that stands proud by a step, as on many food-can ends: (rings, span of their radii, half-width mm, step mm, points)
ENDS = {"rings": (2, (0.4, 0.75), 1.6, 0.0, 90), "flat": (3, (0.7, 0.9), 1.2, 0.8, 120)}


def bead_profile(z: np.ndarray, height: float, beads: int) -> np.ndarray:
    """Radial inset (mm, >= 0) of the side wall at heights ``z``: ``beads`` smooth grooves spaced evenly
    between the plain bands."""
    centres = np.linspace(PLAIN_BAND, height - PLAIN_BAND, beads) if beads else np.zeros(0)
    inset = np.zeros_like(z)
    for c in centres:
        inset += BEAD_DEPTH * np.exp(-(((z - c) / BEAD_WIDTH) ** 2) * 2.5)
    return np.minimum(inset, BEAD_DEPTH)


def end_profile(radius: float, ends: str = "rings") -> np.ndarray:
    """The bottom end from the axis out to the body: (r, z) points, z measured up from the seam's face.

    The panel (recessed by :data:`RECESS`, with the expansion rings of ``ends``) runs into the countersink, the
    chuck wall drops to the seam's face, the seam rounds over its outer edge and tucks back to the body wall."""
    body = radius - SEAM_OVERHANG
    inner = body - 4.5  # the seam's inner edge
    count, span, width, step, points = ENDS[ends]
    outer = inner - 3.0
    panel_r = np.linspace(0.0, outer, points)
    ring_r = np.linspace(*span, count) * outer
    rings = sum(RING_HEIGHT * np.exp(-(((panel_r - c) / width) ** 2)) for c in ring_r)
    centre = step / (1 + np.exp((panel_r - 0.58 * outer) / 0.5))  # the flat centre's step (none on "rings")
    panel = np.stack([panel_r, RECESS - rings - centre], 1)  # rings stand proud: towards the seam's face
    a = np.linspace(0, np.pi, 9)[1:]  # the countersink: a half-round groove into the tin
    sink = np.stack([inner - 1.5 - 1.5 * np.cos(a), RECESS + (COUNTERSINK - RECESS) * np.sin(a)], 1)
    chuck = np.array([[inner + 0.3, 2.0], [inner + 0.5, 0.8]])
    b = np.linspace(np.pi, 1.5 * np.pi, 5)  # inner bottom edge of the seam, rounded
    lip_in = np.stack([inner + 1.0 + 0.5 * np.cos(b), 0.5 + 0.5 * np.sin(b)], 1)
    c = np.linspace(1.5 * np.pi, 2.0 * np.pi, 5)[1:]  # outer bottom edge, rounded
    lip_out = np.stack([radius - 0.8 + 0.8 * np.cos(c), 0.8 + 0.8 * np.sin(c)], 1)
    wall = np.array([[radius, SEAM_HEIGHT - 0.6], [radius - 0.3, SEAM_HEIGHT - 0.1], [body + 0.1, SEAM_HEIGHT],
                     [body, SEAM_HEIGHT + 0.4]])
    return np.concatenate([panel, sink, chuck, lip_in, lip_out, wall])


def profile(diameter: float, height: float, beads: int, ends: str = "rings") -> np.ndarray:
    """The whole outline (r, z) from the bottom's centre, up the side wall, to the top's centre."""
    radius = diameter / 2
    bottom = end_profile(radius, ends)
    z0, z1 = bottom[-1, 1], height - bottom[-1, 1]
    z = np.linspace(z0, z1, max(int((z1 - z0) / 0.5), 2) + 1)[1:-1]
    side = np.stack([radius - SEAM_OVERHANG - bead_profile(z, height, beads), z], 1)
    top = bottom[::-1] * [1, -1] + [0, height]
    return np.concatenate([bottom, side, top])


def revolve(outline: np.ndarray, segments: int) -> np.ndarray:
    """Triangles (k, 3, 3) of the closed surface of revolution of ``outline`` (first and last point on the axis)
    about z, with ``segments`` around; faces point outwards."""
    th = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = outline[1:-1]
    pts = np.stack([ring[:, :1] * np.cos(th), ring[:, :1] * np.sin(th), np.repeat(ring[:, 1:], segments, 1)], -1)
    nxt = np.roll(np.arange(segments), -1)
    a, b = pts[:-1], pts[:-1, nxt]  # ring i
    c, d = pts[1:, nxt], pts[1:]  # ring i + 1
    quads = np.concatenate([np.stack([a, b, c], -2), np.stack([a, c, d], -2)], 1).reshape(-1, 3, 3)
    lo = np.broadcast_to([0, 0, outline[0, 1]], (segments, 3))
    hi = np.broadcast_to([0, 0, outline[-1, 1]], (segments, 3))
    fans = [np.stack([lo, pts[0, nxt], pts[0]], 1), np.stack([hi, pts[-1], pts[-1, nxt]], 1)]
    return np.concatenate([fans[0], quads, fans[1]])


def tin(diameter: float = 73.0, height: float = 110.0, beads: int = 14, segments: int = 128,
        ends: str = "rings") -> np.ndarray:
    """The tin's triangles (mm), standing on its bottom seam at z = 0."""
    if diameter < 20 or height < 2 * PLAIN_BAND or segments < 8 or beads < 0:
        raise ValueError(f"a tin needs diameter >= 20 mm, height >= {2 * PLAIN_BAND:g} mm, segments >= 8, beads >= 0")
    return revolve(profile(diameter, height, beads, ends), segments)


def write_stl(path: Path, tris: np.ndarray) -> None:
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    rec = np.zeros(len(tris), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"], rec["v"] = n, tris
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")  # written whole, then renamed: no half-written mesh on a failure
    tmp.write_bytes(b"deformsim example food tin".ljust(80, b" ") + np.uint32(len(tris)).tobytes() + rec.tobytes())
    tmp.replace(path)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description="Write a ribbed food tin (STL, millimetres).")
    ap.add_argument("out", nargs="?", default="tin.stl", type=Path)
    ap.add_argument("--diameter", type=float, default=73.0, help="across the seams, mm")
    ap.add_argument("--height", type=float, default=110.0, help="seam to seam, mm")
    ap.add_argument("--beads", type=int, default=14, help="beads rolled into the side wall")
    ap.add_argument("--segments", type=int, default=128, help="facets around")
    ap.add_argument("--ends", choices=sorted(ENDS), default="rings", help="the end panels' expansion rings")
    args = ap.parse_args()
    write_stl(args.out, tin(args.diameter, args.height, args.beads, args.segments, args.ends))
    print(f"wrote {args.out}")
