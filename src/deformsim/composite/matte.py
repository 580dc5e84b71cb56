"""Mattes: the exact render alpha, or a chroma key that needs nothing but an image shot in front of a screen.

A matte is ``(alpha, fg)``: ``alpha`` in [0, 1] (float32, HxW) and ``fg`` the *premultiplied* foreground
(float32, HxWx3, 0-255), so a composite over ``bg`` is ``fg + (1 - alpha) * bg``.

The chroma key keeps the paper's settings (key colour, tolerance, opening, closing, erosion) but keys on the
screen channel's dominance ``d = g - max(r, b)``, normalised by the *local* screen level, so uneven, off-key,
noisy real screens work. The hard mask (opened against specks, closed against holes) only decides where the
object surely is; in a band of the erosion's width around its edge, alpha is solved from the local screen
and object dominance, then the screen colour is unmixed and despilled from the edge: a soft edge, no fringe.
"""

from __future__ import annotations

import cv2
import numpy as np

from deformsim.config import CompositeConfig

MIN_SCREEN = 24.0  # screen dominance below this (0-255) means the image has no screen at all
_MIN_CONTRAST = 0.2  # object dominance this close (relative) to the screen's: keep the hard mask


def alpha_matte(rgba: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The exact matte of a straight-alpha RGBA render."""
    alpha = rgba[..., 3].astype(np.float32) / 255.0
    return alpha, rgba[..., :3].astype(np.float32) * alpha[..., None]


def inrange_matte(rgb: np.ndarray, cfg: CompositeConfig) -> tuple[np.ndarray, np.ndarray]:
    """The paper's hard key: ``inRange(key +- tolerance)``, then closing, opening and erosion of the object."""
    key = np.array(cfg.key_color)
    screen = cv2.inRange(rgb, np.clip(key - cfg.tolerance, 0, 255), np.clip(key + cfg.tolerance, 0, 255))
    obj = _morph(_morph(255 - screen, cv2.MORPH_CLOSE, cfg.close_kernel), cv2.MORPH_OPEN, cfg.open_kernel)
    obj = cv2.erode(obj, _kernel(cfg.erode_kernel)) if cfg.erode_kernel > 1 else obj
    alpha = obj.astype(np.float32) / 255.0
    return alpha, rgb.astype(np.float32) * alpha[..., None]


def _kernel(size: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


def _morph(mask: np.ndarray, op: int, size: int) -> np.ndarray:
    return cv2.morphologyEx(mask, op, _kernel(size)) if size > 1 else mask


def _dominance(x: np.ndarray, c: int) -> np.ndarray:
    o1, o2 = [i for i in range(3) if i != c]
    return x[..., c] - np.maximum(x[..., o1], x[..., o2])


def _spread(vals: np.ndarray, m: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Normalised convolution: ``vals`` averaged over the pixels where ``m`` is 1, and that support."""
    num = cv2.GaussianBlur(vals * m[..., None], (0, 0), sigma)
    den = cv2.GaussianBlur(m, (0, 0), sigma)
    return num / np.maximum(den, 1e-6)[..., None], den


def _screen_mask(ds: np.ndarray, thresh, erode: bool) -> np.ndarray:
    m = (ds > thresh).astype(np.uint8)
    if erode and cv2.erode(m, _kernel(3)).any():  # coarse pixels at the object's edge are mixed: drop them
        m = cv2.erode(m, _kernel(3))
    return m.astype(np.float32)


def _screen_model(x: np.ndarray, c: int, t: float) -> tuple[np.ndarray, float]:
    """Screen colour and dominance on a coarse grid (about 48 px), interpolated under the object.

    Two passes: the screen is first what Otsu's threshold separates, then every pixel at least half as
    dominant as the screen around it (which takes in shadows and falloff). Near the screen a fine average
    follows its unevenness; under the object a wide one bridges the gap.
    """
    h, w = x.shape[:2]
    f = min(1.0, 48.0 / max(h, w))
    size = (max(1, round(w * f)), max(1, round(h * f)))
    small = cv2.resize(x, size, interpolation=cv2.INTER_AREA)
    vals = np.dstack([small, _dominance(small, c)])
    m = _screen_mask(vals[..., 3], t, f < 1.0)
    for _ in range(2):
        glob = (vals * m[..., None]).sum(axis=(0, 1)) / max(m.sum(), 1e-6)
        wide, den = _spread(vals, m, max(size) / 8.0)
        wide = np.where((den > 1e-3)[..., None], wide, glob)
        fine, support = _spread(vals, m, 1.0)
        near = np.clip(support / 0.3, 0.0, 1.0)[..., None]
        grid = (near * fine + (1.0 - near) * wide).astype(np.float32)
        m = _screen_mask(vals[..., 3], np.maximum(0.5 * grid[..., 3], MIN_SCREEN), f < 1.0)
    return grid, f


def _sample(grid: np.ndarray, f: float, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Bilinear samples of a coarse grid (made with ``cv2.resize`` by factor ``f``) at full-size pixels."""
    mx = ((xs + 0.5) * f - 0.5).astype(np.float32).reshape(-1, 1)
    my = ((ys + 0.5) * f - 0.5).astype(np.float32).reshape(-1, 1)
    return cv2.remap(grid, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).reshape(len(ys), -1)


def chroma_matte(rgb: np.ndarray, cfg: CompositeConfig) -> tuple[np.ndarray, np.ndarray]:
    """Key an RGB uint8 image shot in front of a ``cfg.key_color`` screen; returns ``(alpha, fg)``."""
    x = rgb.astype(np.float32)
    c = int(np.argmax(cfg.key_color))
    d = _dominance(x, c)
    d8 = np.clip(d, 0, 255).astype(np.uint8)
    t, _ = cv2.threshold(d8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    if cv2.mean(d8, (d8 > t).astype(np.uint8))[0] < MIN_SCREEN:
        return np.ones(d.shape, np.float32), x
    grid, scale = _screen_model(x, c, t)
    level = cv2.resize(np.ascontiguousarray(grid[..., 3]), d.shape[::-1], interpolation=cv2.INTER_LINEAR)
    k = d / np.maximum(level, MIN_SCREEN)  # 1 on the screen, <= 0 on a neutral object
    hard = (k < 1.0 - cfg.tolerance / 255.0).astype(np.uint8)
    hard = _morph(_morph(hard, cv2.MORPH_OPEN, cfg.open_kernel), cv2.MORPH_CLOSE, cfg.close_kernel)
    e = cfg.erode_kernel
    core = cv2.erode(hard, _kernel(e)) if e > 1 else hard
    outer = cv2.dilate(hard, _kernel(e)) if e > 1 else hard
    alpha = core.astype(np.float32)
    fg = x * alpha[..., None]
    ys, xs = np.nonzero(outer > core)  # the edge band, solved pixel by pixel
    if len(ys):
        a, f = _solve_edge(x, d, alpha, fg, grid, scale, c, ys, xs, hard[ys, xs])
        alpha[ys, xs] = a
        fg[ys, xs] = f
    return alpha, fg


def _solve_edge(x, d, alpha, fg, grid, scale, c, ys, xs, hard):
    """Alpha and unmixed, despilled premultiplied colour of edge pixels from the local screen and object.

    With screen dominance ``d_b`` and object dominance ``d_f``, a pixel mixing them has
    ``d = a d_f + (1 - a) d_b``. ``d_f`` comes from the nearest sure-object pixels; edge pixels are less
    saturated than those (grazing light, pixel filter), so a negative ``d_f`` is halved: the middle of the
    range it can take, which halves the worst-case error.
    """
    o1, o2 = [i for i in range(3) if i != c]
    weight = cv2.GaussianBlur(alpha, (7, 7), 1.5)[ys, xs]
    fcol = cv2.GaussianBlur(fg, (7, 7), 1.5)[ys, xs] / np.maximum(weight, 1e-6)[:, None]
    bcol = _sample(np.ascontiguousarray(grid[..., :3]), scale, ys, xs)
    d_b = _sample(np.ascontiguousarray(grid[..., 3]), scale, ys, xs)[:, 0]
    d_f = _dominance(fcol, c)
    d_f = np.where(d_f < 0, 0.5 * d_f, d_f)
    ok = (weight > 1e-3) & (d_b - d_f > _MIN_CONTRAST * d_b)
    solved = np.clip((d_b - d[ys, xs]) / np.maximum(d_b - d_f, 1e-6), 0.0, 1.0)
    a = np.where(ok, solved, hard.astype(np.float32))
    f = np.clip(x[ys, xs] - (1.0 - a)[:, None] * bcol, 0.0, 255.0 * a[:, None])  # unmix the screen out
    # despill: an edge pixel may be no more screen-coloured than the object next to it
    f[:, c] = np.minimum(f[:, c], np.maximum(f[:, o1], f[:, o2]) + a * np.maximum(d_f, 0.0))
    return a, f * (a > 0)[:, None]


def binary_iou(a: np.ndarray, b: np.ndarray, threshold: float = 0.5) -> float:
    """IoU of two mattes binarised at ``threshold`` (1.0 when both are empty)."""
    ma, mb = a > threshold, b > threshold
    union = np.logical_or(ma, mb).sum()
    return float(np.logical_and(ma, mb).sum() / union) if union else 1.0
