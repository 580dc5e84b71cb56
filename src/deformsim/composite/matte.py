"""Mattes: the exact render alpha, or a chroma key that needs nothing but an image shot in front of a screen.

A matte is ``(alpha, fg)``: ``alpha`` in [0, 1] (float32, HxW) and ``fg`` the *premultiplied* foreground
(float32, HxWx3, 0-255), so a composite over ``bg`` is ``fg + (1 - alpha) * bg``.

The chroma key follows the paper (key colour, tolerance, closing, opening, erosion) but keys on the screen
channel's dominance ``d = g - max(r, b)``, normalised by the *local* screen level, so uneven, noisy real
screens work. The hard mask only decides where the object surely is; in a band around its edge the alpha
is solved from the local screen and object colours (``C = a F + (1 - a) B``) and the screen colour is
removed from the edge (unmix + despill), which leaves a soft edge without a green fringe.
"""

from __future__ import annotations

import cv2
import numpy as np

from deformsim.config import CompositeConfig

MIN_SCREEN = 24.0  # screen dominance below this (0-255) means the image has no screen at all
_MIN_CONTRAST = 20.0**2  # |F - B|^2 below this: the object looks like the screen, keep the hard mask


def alpha_matte(rgba: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The exact matte of a straight-alpha RGBA render."""
    alpha = rgba[..., 3].astype(np.float32) / 255.0
    return alpha, rgba[..., :3].astype(np.float32) * alpha[..., None]


def _kernel(size: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


def _morph(mask: np.ndarray, op: int, size: int) -> np.ndarray:
    return cv2.morphologyEx(mask, op, _kernel(size)) if size > 1 else mask


def _smooth_screen(x: np.ndarray, d: np.ndarray, screen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local screen colour and dominance, interpolated under the object (solved at about 48 px)."""
    h, w = d.shape
    f = min(1.0, 48.0 / max(h, w))
    size = (max(1, round(w * f)), max(1, round(h * f)))
    m = screen.astype(np.float32)
    vals = np.dstack([x, d]) * m[..., None]
    num = cv2.GaussianBlur(cv2.resize(vals, size, interpolation=cv2.INTER_AREA), (0, 0), max(size) / 8.0)
    den = cv2.GaussianBlur(cv2.resize(m, size, interpolation=cv2.INTER_AREA), (0, 0), max(size) / 8.0)
    glob = vals.sum(axis=(0, 1)) / m.sum()
    small = np.where((den > 1e-3)[..., None], num / np.maximum(den, 1e-6)[..., None], glob).astype(np.float32)
    full = cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)
    return full[..., :3], full[..., 3]


def chroma_matte(rgb: np.ndarray, cfg: CompositeConfig) -> tuple[np.ndarray, np.ndarray]:
    """Key an RGB uint8 image shot in front of a ``cfg.key_color`` screen; returns ``(alpha, fg)``."""
    x = rgb.astype(np.float32)
    c = int(np.argmax(cfg.key_color))
    o1, o2 = [i for i in range(3) if i != c]
    d = x[..., c] - np.maximum(x[..., o1], x[..., o2])
    d8 = np.clip(d, 0, 255).astype(np.uint8)
    t, _ = cv2.threshold(d8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    screen = d8 > t
    if not screen.any() or d[screen].mean() < MIN_SCREEN:
        return np.ones(d.shape, np.float32), x
    bcol, level = _smooth_screen(x, d, screen)
    k = d / np.maximum(level, MIN_SCREEN)  # 1 on the screen, <= 0 on a neutral object
    hard = (k < 1.0 - cfg.tolerance / 255.0).astype(np.uint8)
    hard = _morph(_morph(hard, cv2.MORPH_CLOSE, cfg.close_kernel), cv2.MORPH_OPEN, cfg.open_kernel)
    e = cfg.erode_kernel
    core = cv2.erode(hard, _kernel(e)) if e > 1 else hard
    outer = cv2.dilate(hard, _kernel(e)) if e > 1 else hard
    alpha = core.astype(np.float32)
    fg = x * alpha[..., None]
    ys, xs = np.nonzero(outer > core)  # the edge band: solved pixel by pixel
    if len(ys):
        wcore = cv2.GaussianBlur(alpha, (0, 0), 1.5)[ys, xs]
        fcol = cv2.GaussianBlur(fg, (0, 0), 1.5)[ys, xs] / np.maximum(wcore, 1e-6)[:, None]
        cpx, bpx = x[ys, xs], bcol[ys, xs]
        fb = fcol - bpx
        den = (fb * fb).sum(-1)
        solved = np.clip(((cpx - bpx) * fb).sum(-1) / np.maximum(den, 1e-6), 0.0, 1.0)
        a = np.where((wcore > 1e-3) & (den > _MIN_CONTRAST), solved, hard[ys, xs].astype(np.float32))
        f = np.clip(cpx - (1.0 - a)[:, None] * bpx, 0.0, 255.0)  # unmix the screen out of the edge
        # despill: an edge pixel may be no more screen-coloured than the object next to it
        d_obj = np.maximum(fcol[:, c] - np.maximum(fcol[:, o1], fcol[:, o2]), 0.0)
        f[:, c] = np.minimum(f[:, c], np.maximum(f[:, o1], f[:, o2]) + a * d_obj)
        alpha[ys, xs] = a
        fg[ys, xs] = f * (a > 0)[:, None]
    return alpha, fg


def binary_iou(a: np.ndarray, b: np.ndarray, threshold: float = 0.5) -> float:
    """IoU of two mattes binarised at ``threshold`` (1.0 when both are empty)."""
    ma, mb = a > threshold, b > threshold
    union = np.logical_or(ma, mb).sum()
    return float(np.logical_and(ma, mb).sum() / union) if union else 1.0
