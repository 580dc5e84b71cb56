"""Dense ground-truth maps written beside each render: encode, write and read them back.

Formats (``images/KIND/ID.png``, one per :data:`deformsim.dataset.layout.DENSE_KINDS`):

- ``mask``    8-bit L, 255 where the part covers the pixel (render alpha >= 0.5), else 0;
- ``depth``   16-bit, camera depth along the view axis in mm, 0 where no part;
- ``normal``  8-bit RGB, camera-space unit normal (x right, y up, z to the viewer) as round((n+1)/2*255), 0 off the part;
- ``deform``  16-bit, displacement of the visible surface point vs its rest position in 0.01 mm (:data:`DEFORM_SCALE`);
- ``region``  8-bit L, 255 where the part is visible and deformed by at least the threshold (mm), else 0.
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


def region_mask(deform_mm: np.ndarray, mask: np.ndarray, threshold_mm: float) -> np.ndarray:
    """Visible pixels deformed by at least ``threshold_mm`` (compare the stored 0.01 mm values, so reading back agrees)."""
    stored = encode_u16(deform_mm, DEFORM_SCALE)
    return mask & (stored >= np.rint(threshold_mm * DEFORM_SCALE))


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
