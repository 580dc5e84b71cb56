"""Camera effects applied to a finished composite: what a phone camera does to a photo.

Each effect is drawn per image from the image's own generator and returned as a record for the manifest,
so a variant is reproducible and every image says what was done to it. An effect whose range is None is off.
Order: exposure and white balance (in linear light), vignetting, defocus blur, motion blur, sensor noise, JPEG.
"""

from __future__ import annotations

import cv2
import numpy as np

from deformsim.config import CameraEffects


def _to_linear(srgb: np.ndarray) -> np.ndarray:
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def _to_srgb(lin: np.ndarray) -> np.ndarray:
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin <= 0.0031308, lin * 12.92, 1.055 * lin ** (1 / 2.4) - 0.055)


def motion_kernel(length: float, angle: float) -> np.ndarray:
    """A normalised line kernel ``length`` pixels long at ``angle`` degrees: points along the line, splatted
    bilinearly, so it is centred and symmetric at any length and angle."""
    size = (int(np.ceil(length)) + 2) | 1
    c, t = (size - 1) / 2, np.radians(angle)
    s = np.linspace(-length / 2, length / 2, 16 * size)
    x, y = c + s * np.cos(t), c + s * np.sin(t)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    k = np.zeros((size + 1, size + 1), np.float64)
    for dy, wy in ((0, 1 - fy), (1, fy)):
        for dx, wx in ((0, 1 - fx), (1, fx)):
            np.add.at(k, (y0 + dy, x0 + dx), wx * wy)
    k = k[:size, :size]
    return (k / k.sum()).astype(np.float32)


def apply_effects(img: np.ndarray, fx: CameraEffects, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """``img`` (H, W, 3 uint8 RGB) with the effects of ``fx`` drawn from ``rng``; and what was drawn."""
    info: dict = {}
    x = img.astype(np.float32) / 255.0
    gains = np.ones(3, np.float32)
    if fx.exposure is not None:
        stops = float(rng.uniform(*fx.exposure))
        gains *= 2.0**stops
        info["fx_exposure"] = stops
    if fx.white_balance is not None:
        shift = float(rng.uniform(*fx.white_balance))  # warm (> 0) or cool (< 0)
        gains *= np.array([1 + shift, 1.0, 1 - shift], np.float32)
        info["fx_white_balance"] = shift
    if fx.exposure is not None or fx.white_balance is not None:
        x = _to_srgb(_to_linear(x) * gains).astype(np.float32)
    h, w = x.shape[:2]
    if fx.vignette is not None:
        strength = float(rng.uniform(*fx.vignette))
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((xx - (w - 1) / 2) / (w / 2)) ** 2 + ((yy - (h - 1) / 2) / (h / 2)) ** 2
        x = x * (1 - strength * np.clip(r2 / 2, 0, 1))[..., None]
        info["fx_vignette"] = strength
    if fx.blur is not None:
        sigma = float(rng.uniform(*fx.blur)) * min(h, w)  # as a fraction of the image size
        if sigma > 0.05:
            x = cv2.GaussianBlur(x, (0, 0), sigmaX=sigma, sigmaY=sigma, borderType=cv2.BORDER_REFLECT)
        info["fx_blur"] = sigma
    if fx.motion_blur is not None:
        length = float(rng.uniform(*fx.motion_blur)) * min(h, w)
        angle = float(rng.uniform(0, 180))
        if length > 1.0:
            x = cv2.filter2D(x, -1, motion_kernel(length, angle), borderType=cv2.BORDER_REFLECT)
        info["fx_motion_blur"], info["fx_motion_angle"] = length, angle
    if fx.noise is not None:
        std = float(rng.uniform(*fx.noise))
        x = x + rng.normal(0.0, std, size=x.shape).astype(np.float32)
        info["fx_noise"] = std
    out = np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)
    if fx.jpeg_quality is not None:
        quality = int(rng.integers(fx.jpeg_quality[0], fx.jpeg_quality[1] + 1))
        ok, buf = cv2.imencode(".jpg", cv2.cvtColor(out, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            raise RuntimeError("JPEG encoding failed")
        out = cv2.cvtColor(cv2.imdecode(buf, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        info["fx_jpeg_quality"] = quality
    return out, info
