"""Framing: crop a matted render around the object so it fills the frame the way a person frames a photo.

The object's box comes from its alpha. A square window is chosen so that the box's longer side fills
``fill`` of the window's side, centred on the box with a random offset, kept inside the render; the
window is resized back to the render's size. Only the foreground, its alpha and its dense maps are cropped
(the maps with nearest-neighbour sampling, so they stay exact labels), so the background photo behind them stays
at full sharpness.
"""

from __future__ import annotations

import cv2
import numpy as np


def object_box(alpha: np.ndarray, level: float = 0.5) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` (exclusive ends) of the pixels with alpha above ``level``; None when empty."""
    ys, xs = np.nonzero(alpha > level)
    if len(xs) == 0:
        return None
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def crop_window(box: tuple[int, int, int, int], shape: tuple[int, int], fill: float, offset: float,
                rng: np.random.Generator) -> tuple[float, float, float]:
    """``(x, y, side)`` of the square window (may be fractional) for an object ``box`` in an image of ``shape``."""
    h, w = shape
    x0, y0, x1, y1 = box
    side = min(max(x1 - x0, y1 - y0) / fill, h, w)
    cx = (x0 + x1) / 2 + offset * side * rng.uniform(-1, 1)
    cy = (y0 + y1) / 2 + offset * side * rng.uniform(-1, 1)
    x = float(np.clip(cx - side / 2, 0, w - side))
    y = float(np.clip(cy - side / 2, 0, h - side))
    return x, y, float(side)


def frame_matrix(alpha: np.ndarray, fill_range: tuple[float, float], offset: float,
                 rng: np.random.Generator) -> tuple[np.ndarray | None, dict]:
    """The 2x3 affine map from the render to the framed output (None: leave as rendered) and its record."""
    h, w = alpha.shape
    fill = float(rng.uniform(*fill_range))
    box = object_box(alpha)
    if box is None:
        return None, {"frame_fill": fill, "frame_x": 0.0, "frame_y": 0.0, "frame_side": float(min(h, w))}
    x, y, side = crop_window(box, (h, w), fill, offset, rng)
    # an affine map from the window to the output: exact for fractional windows, no double resampling
    m = np.array([[w / side, 0, -x * w / side], [0, h / side, -y * h / side]], np.float32)
    return m, {"frame_fill": fill, "frame_x": x, "frame_y": y, "frame_side": side}


def warp(img: np.ndarray, m: np.ndarray | None, nearest: bool = False) -> np.ndarray:
    """``img`` through the framing map ``m``: area/linear for pictures, nearest for label and measurement maps."""
    if m is None:
        return img
    h, w = img.shape[:2]
    if nearest:
        interp = cv2.INTER_NEAREST
    else:
        interp = cv2.INTER_LINEAR if w / m[0, 0] < min(h, w) else cv2.INTER_AREA  # window smaller than the render
        img = img.astype(np.float32)
    return cv2.warpAffine(img, m, (w, h), flags=interp, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
