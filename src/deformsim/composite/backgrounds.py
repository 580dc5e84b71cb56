"""Backgrounds: photos from a folder (searched recursively) or procedural ones that need no data.

Every random choice comes from the caller's generator, so a background is a pure function of the image's
seed. A photo is decoded at reduced size when it is much larger than needed (JPEG draft mode).
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from deformsim.dataset.images import IMAGE_EXTS, images_in, open_rgb
from deformsim.errors import UserError
from deformsim.identity import files_digest

PROCEDURAL_KINDS = ("gradient", "noise", "shapes", "texture")
MAX_KEY_DOMINANCE = 96  # procedural colours never look like a green screen (g - max(r, b) stays below)


class BackgroundWarning(UserWarning):
    """A background file was skipped."""


def photos_digest(folder: str | Path | None) -> str | None:
    """The contents of the photos under ``folder`` (their names in it and their bytes); None without a folder."""
    return files_digest(images_in(Path(folder)), folder) if folder is not None and Path(folder).is_dir() else None


def scan_backgrounds(folder: str | Path) -> list[Path]:
    """Image files under ``folder`` (recursive, sorted) whose header reads; warns naming each skipped one.

    Raises :class:`UserError` when the folder is missing or holds no readable image.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"background folder not found: {folder}")
    found = []
    for p in images_in(folder):
        try:
            with Image.open(p) as im:
                im.size  # noqa: B018 - parse the header
            found.append(p)
        except Exception as exc:  # PIL raises many types for bad files
            warn_skipped(p, exc)
    if not found:
        raise UserError(f"background folder {folder} holds no readable image ({', '.join(sorted(IMAGE_EXTS))})")
    return found


def warn_skipped(path: Path, reason: object) -> None:
    warnings.warn(f"skipping unreadable background {path}: {reason}", BackgroundWarning, stacklevel=2)


@lru_cache(maxsize=48)
def load_photo(path: str, min_w: int, min_h: int) -> np.ndarray:
    """RGB uint8 pixels of a photo (the package's one loader, :func:`open_rgb`), decoded at the smallest draft
    size still covering ``min_w x min_h``.

    Raises :class:`UserError` for corrupt or truncated files.
    """
    return np.asarray(open_rgb(path, (min_w, min_h)))


def fit(photo: np.ndarray, h: int, w: int, rng: np.random.Generator, scale: tuple[float, float], flip: bool):
    """Aspect-preserving cover-resize and crop of ``photo`` to ``h x w`` with scale jitter and flip.

    Returns ``(rgb, params)`` with the crop's position as fractions of the photo's size.
    """
    ph, pw = photo.shape[:2]
    s = float(rng.uniform(*scale))
    cw, ch = min(pw, w / (s * max(w / pw, h / ph))), min(ph, h / (s * max(w / pw, h / ph)))
    x0, y0 = float(rng.uniform(0, pw - cw)), float(rng.uniform(0, ph - ch))
    mirror = bool(flip and rng.random() < 0.5)
    crop = photo[int(y0) : max(int(y0) + 1, round(y0 + ch)), int(x0) : max(int(x0) + 1, round(x0 + cw))]
    interp = cv2.INTER_AREA if crop.shape[1] > w else cv2.INTER_LINEAR
    out = cv2.resize(crop, (w, h), interpolation=interp)
    if mirror:
        out = out[:, ::-1]
    return np.ascontiguousarray(out), {"bg_x": x0 / pw, "bg_y": y0 / ph, "bg_scale": s, "bg_flip": mirror}


def random_colors(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` colours (float 0-255) around a random hue, with a random spread of saturation and value."""
    base = rng.uniform(0, 180)
    hsv = np.stack(
        [(base + rng.normal(0, 25, n)) % 180, rng.uniform(20, 200, n), rng.uniform(40, 245, n)], axis=-1
    )
    return cv2.cvtColor(hsv.astype(np.uint8)[None], cv2.COLOR_HSV2RGB)[0].astype(np.float32)


def _noise(rng: np.random.Generator, h: int, w: int, octaves: int = 5) -> np.ndarray:
    """Fractal value noise in [0, 1]."""
    out = np.zeros((h, w), np.float32)
    amp, total = 1.0, 0.0
    for o in range(octaves):
        cells = 2 ** (o + 1)
        grid = rng.random((cells + 1, cells + 1)).astype(np.float32)
        out += amp * cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC)
        total += amp
        amp *= 0.55
    out /= total
    return (out - out.min()) / max(float(np.ptp(out)), 1e-6)


def _ramp(t: np.ndarray, colors: np.ndarray) -> np.ndarray:
    """Map ``t`` in [0, 1] through a piecewise-linear colour ramp."""
    stops = np.linspace(0, 1, len(colors))
    return np.stack([np.interp(t, stops, colors[:, i]) for i in range(3)], axis=-1).astype(np.float32)


def procedural(kind: str, seed: int, h: int, w: int) -> np.ndarray:
    """A procedural RGB uint8 background; the same ``(kind, seed, h, w)`` always gives the same image."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32) / max(h, w)
    ang = rng.uniform(0, 2 * np.pi)
    u = xx * np.cos(ang) + yy * np.sin(ang)
    if kind == "gradient":
        if rng.random() < 0.5:
            cx, cy = rng.uniform(0, 1, 2)
            u = np.hypot(xx - cx, yy - cy)
        img = _ramp((u - u.min()) / max(float(np.ptp(u)), 1e-6), random_colors(rng, int(rng.integers(2, 4))))
        img += rng.normal(0, 3, img.shape).astype(np.float32)
    elif kind == "noise":
        img = _ramp(_noise(rng, h, w), random_colors(rng, int(rng.integers(2, 5))))
    elif kind == "texture":
        freq = rng.uniform(6, 40)
        warp = _noise(rng, h, w, 4) * rng.uniform(0, 8)
        t = 0.5 + 0.5 * np.sin(2 * np.pi * freq * u + warp)
        if rng.random() < 0.4:  # checks instead of stripes
            v = -xx * np.sin(ang) + yy * np.cos(ang)
            t = ((np.floor(u * freq / 2) + np.floor(v * freq / 2)) % 2) * 0.7 + 0.3 * t
        img = _ramp(t, random_colors(rng, 2)) * (0.75 + 0.25 * _noise(rng, h, w, 3))[..., None]
    elif kind == "shapes":
        img = _ramp((u - u.min()) / max(float(np.ptp(u)), 1e-6), random_colors(rng, 2))
        cols = random_colors(rng, 12)
        for i in range(int(rng.integers(4, 13))):
            col = tuple(float(v) for v in cols[i % len(cols)])
            cx, cy = int(rng.integers(0, w)), int(rng.integers(0, h))
            r = int(rng.integers(max(2, min(h, w) // 20), max(3, min(h, w) // 3)))
            shape = rng.integers(0, 3)
            if shape == 0:
                cv2.circle(img, (cx, cy), r, col, -1, cv2.LINE_AA)
            elif shape == 1:
                cv2.rectangle(img, (cx - r, cy - r // 2), (cx + r, cy + r // 2), col, -1, cv2.LINE_AA)
            else:
                end = (int(rng.integers(0, w)), int(rng.integers(0, h)))
                cv2.line(img, (cx, cy), end, col, max(1, r // 6), cv2.LINE_AA)
        img = cv2.GaussianBlur(img, (3, 3), 0.7)
    else:
        raise UserError(f"unknown procedural background kind {kind!r} (have: {', '.join(PROCEDURAL_KINDS)})")
    return _limit_key(np.clip(img, 0, 255)).astype(np.uint8)


def _limit_key(img: np.ndarray) -> np.ndarray:
    """Cap green dominance so a procedural background can never be mistaken for the screen."""
    img[..., 1] = np.minimum(img[..., 1], np.maximum(img[..., 0], img[..., 2]) + MAX_KEY_DOMINANCE)
    return img
