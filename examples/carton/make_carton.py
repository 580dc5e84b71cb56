"""Write `carton.stl`: a 70 x 70 x 190 mm drink carton with a gable top, finely subdivided (units: mm).

A stand-in for a user's CAD export, used by the docs/your-part.md walk-through and the tests:
    python examples/carton/make_carton.py OUT.stl
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

W, H, ROOF, N = 70.0, 190.0, 25.0, 24  # width, wall height, gable height, subdivisions per side


def quad_grid(corner, du, dv, n: int) -> np.ndarray:
    """Triangles (k, 3, 3) of an n x n grid over the parallelogram corner + s*du + t*dv."""
    s = np.linspace(0, 1, n + 1)
    p = corner + s[:, None, None] * du + s[None, :, None] * dv
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], -2), np.stack([a, c, d], -2)]).reshape(-1, 3, 3)


def carton() -> np.ndarray:
    h = W / 2
    x, y, z = np.eye(3)
    tris = [
        quad_grid(np.array([-h, -h, 0]), W * y, W * x, N),  # bottom (facing down)
        quad_grid(np.array([-h, -h, 0]), W * x, H * z, N),  # front
        quad_grid(np.array([h, h, 0]), -W * x, H * z, N),  # back
        quad_grid(np.array([h, -h, 0]), W * y, H * z, N),  # right
        quad_grid(np.array([-h, h, 0]), -W * y, H * z, N),  # left
        quad_grid(np.array([-h, -h, H]), W * x, np.array([0, h, ROOF]), N),  # roof, front slope
        quad_grid(np.array([h, h, H]), -W * x, np.array([0, -h, ROOF]), N),  # roof, back slope
    ]
    for sx in (-h, h):  # gable triangles on the sides
        apex = np.array([sx, 0, H + ROOF])
        a, b = np.array([sx, -h, H]), np.array([sx, h, H])
        tris.append(np.array([[a, b, apex] if sx > 0 else [b, a, apex]]))
    return np.concatenate(tris)


def write_stl(path: Path, tris: np.ndarray) -> None:
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    rec = np.zeros(len(tris), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"], rec["v"] = n, tris
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")  # written whole, then renamed: no half-written mesh on a failure
    tmp.write_bytes(b"deformsim example carton".ljust(80, b" ") + np.uint32(len(tris)).tobytes() + rec.tobytes())
    tmp.replace(path)


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "carton.stl")
    write_stl(out, carton())
    print(f"wrote {out}")
