"""Dense ground-truth maps written beside each render: encode, write and read them back.

Formats (``images/KIND/ID.png``, one per :data:`deformsim.dataset.layout.DENSE_KINDS`):

- ``mask``    8-bit L, 255 where the part covers the pixel (render alpha >= 0.5), else 0;
- ``depth``   16-bit, camera depth along the view axis in mm, 0 where no part;
- ``normal``  8-bit RGB, camera-space unit normal (x right, y up, z to the viewer) as round((n+1)/2*255), 0 off the part;
- ``deform``  16-bit, displacement of the visible surface point vs its rest position in 0.01 mm (:data:`DEFORM_SCALE`);
- ``region``  8-bit L, 255 where the part is visible and deformed by at least the threshold (mm), else 0; with
  ``render.region_visible`` set, only where that shows in the image (:func:`shown`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from deformsim.atomic import atomic_path

DEFORM_SCALE = 100.0  # stored units per mm
U16_MAX = 65535


def save_png(path: str | Path, array: np.ndarray) -> None:
    """Write an 8-bit (L or RGB) or 16-bit (uint16, mode I;16) array as PNG, atomically."""
    with atomic_path(path) as tmp:
        Image.fromarray(array).save(tmp, format="PNG")


def encode_u16(values: np.ndarray, scale: float) -> np.ndarray:
    """``round(values * scale)`` clipped to uint16; NaN and negatives become 0."""
    v = np.nan_to_num(np.asarray(values, dtype=np.float64) * scale, nan=0.0, posinf=U16_MAX, neginf=0.0)
    return np.clip(np.rint(v), 0, U16_MAX).astype(np.uint16)


def encode_normal(normal: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) unit normals -> 8-bit RGB round((n+1)/2*255), (0, 0, 0) outside ``mask``."""
    n = np.clip(np.nan_to_num(normal), -1.0, 1.0)
    rgb = np.rint((n + 1.0) / 2.0 * 255.0).astype(np.uint8)
    rgb[~mask] = 0
    return rgb


def mask_image(mask: np.ndarray) -> np.ndarray:
    """Bool array -> 8-bit L (255 / 0)."""
    return np.where(mask, 255, 0).astype(np.uint8)


def region_mask(deform_mm: np.ndarray, mask: np.ndarray, threshold_mm: float,
                shown: np.ndarray | None = None) -> np.ndarray:
    """Visible pixels deformed by at least ``threshold_mm`` (compare the stored 0.01 mm values, so reading back agrees)
    and, when ``shown`` is given, where it is true (:func:`shown`)."""
    stored = encode_u16(deform_mm, DEFORM_SCALE)
    region = mask & (stored >= np.rint(threshold_mm * DEFORM_SCALE))
    return region if shown is None else region & shown


def shown(across_px: np.ndarray, turn_deg: np.ndarray, min_across_px: float, min_turn_deg: float) -> np.ndarray:
    """Pixels whose displacement shows in the image (``render.region_visible``): moved across it (perpendicular to
    the line of sight; with ``view_fit``, beyond the visible part's own affine motion, :func:`beyond_affine`) by at
    least ``min_across_px`` pixels, or turned by at least ``min_turn_deg``. Movement along the line of sight that
    barely turns the surface leaves the image as it was."""
    return (across_px >= min_across_px) | (turn_deg >= min_turn_deg)


def beyond_affine(u: np.ndarray, v: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per pixel, the length of the image motion (``u``, ``v``: pixels along the image's two axes) left after the
    affine map of the image that best fits it over ``mask`` (least squares); 0 outside ``mask``. A visible part
    moved, turned, tilted a little or resized as a whole leaves nothing: an intact part placed so looks the same."""
    rows, cols = np.nonzero(mask)
    out = np.zeros(mask.shape, dtype=np.float64)
    if len(rows) < 3:
        return out
    design = np.column_stack([cols, rows, np.ones(len(rows))]).astype(np.float64)
    motion = np.column_stack([u[mask], v[mask]]).astype(np.float64)
    coef, *_ = np.linalg.lstsq(design, motion, rcond=None)
    out[mask] = np.linalg.norm(motion - design @ coef, axis=1)
    return out


def vertex_normals(co: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Unit vertex normals of the triangles ``tris`` ((T, 3) vertex indices) over positions ``co`` ((N, 3)):
    the area-weighted mean of the normals of the triangles around each vertex (zero for a vertex in none)."""
    co = np.asarray(co, dtype=np.float64)
    a, b, c = (co[tris[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)  # length: twice the area
    normals = np.zeros_like(co)
    for k in range(3):
        np.add.at(normals, tris[:, k], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def bend_deg(rest: np.ndarray, moved: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per vertex, the angle in degrees between its normal on ``rest`` and on ``moved`` (same triangles): how far
    the deformation turned the surface there. Moving a patch without turning it (an end pushed straight in) gives
    0. Place ``rest`` by :func:`rigid_fit` or :func:`scaled_fit` first, so that the part's rigid motion does not
    count."""
    cos = np.sum(vertex_normals(rest, tris) * vertex_normals(moved, tris), axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).astype(np.float32)


def rigid_fit(rest: np.ndarray, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t that best map ``rest`` onto ``moved`` (least squares, Kabsch): (N, 3) each.

    ``rest @ R.T + t`` is the undeformed part placed where it fits the deformed one best, so that displacement
    measured from it is deformation, not the rigid motion a global bend or twist also causes.
    """
    a, b = np.asarray(rest, dtype=np.float64), np.asarray(moved, dtype=np.float64)
    ca, cb = a.mean(0), b.mean(0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, cb - ca @ r.T


def scaled_fit(rest: np.ndarray, moved: np.ndarray, steps: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A = R diag(s) and t that best map ``rest`` onto ``moved`` with a scale per axis of ``rest``'s frame: a
    change of size along the part's own axes (what ``object.shapes`` draws for intact parts too) is left out with
    the rigid motion. Alternates :func:`rigid_fit` with the per-axis least-squares scale."""
    a, b = np.asarray(rest, dtype=np.float64), np.asarray(moved, dtype=np.float64)
    centred = a - a.mean(0)
    spread = np.maximum((centred**2).sum(0), 1e-18)
    s = np.ones(3)
    for _ in range(steps):
        r, t = rigid_fit(a * s, b)
        back = (b - t) @ r  # moved in rest's frame
        s = (centred * (back - back.mean(0))).sum(0) / spread
    r, t = rigid_fit(a * s, b)
    return r * s, t


def read_deform_mm(path: str | Path) -> np.ndarray:
    """A ``deform`` map back in millimetres (float32)."""
    with Image.open(path) as im:
        return np.asarray(im, dtype=np.float32) / DEFORM_SCALE


def read_depth_mm(path: str | Path) -> np.ndarray:
    """A ``depth`` map in millimetres (float32; 0 where no part)."""
    with Image.open(path) as im:
        return np.asarray(im, dtype=np.float32)


def read_mask(path: str | Path) -> np.ndarray:
    """A ``mask`` or ``region`` image as a bool array (pixel >= 128)."""
    with Image.open(path) as im:
        return np.asarray(im.convert("L")) >= 128


def mask_bbox(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) of the true pixels, x1 and y1 exclusive; None when the mask is empty."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return None
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def map_stats(mask: np.ndarray, deform_mm: np.ndarray, region: np.ndarray) -> dict:
    """The per-image manifest columns of a set of maps: ``bbox_*``, ``visible_disp_mm``, ``region_fraction``."""
    box = mask_bbox(mask) or (-1, -1, -1, -1)
    covered = int(mask.sum())
    return {
        **{f"bbox_{k}": int(v) for k, v in zip(("x0", "y0", "x1", "y1"), box)},
        "visible_disp_mm": float(deform_mm[mask].max()) if covered else 0.0,
        "region_fraction": float(region.sum() / covered) if covered else 0.0,
    }
