"""Printed artwork like real cans (``render.appearance``; pure numpy + PIL, no Blender).

:func:`make_artwork` draws a sample's label as colour plus a *metal* mask: 1 where the aluminium shows (bare metal,
or metallic inks printed without the white basecoat, so the silver shines through), 0 where opaque ink is. Styles:
``designer`` (gradients, fine graphics: pinstripes, halftone dots, hatching, ribbons, rays and confetti; a logo
badge and the brand word; small text blocks; nutrition panel and barcode), ``bare`` (a bare-metal body with a few
inks on it), ``photo`` (a crop of an artwork photo, sometimes with the brand word on it) and ``plain`` (the label of
:mod:`~deformsim.blender.part.can_label`). Like that label, column ``x`` is the angle ``u = x / width`` around the can
and everything crossing the seam at ``u = 0`` has whole periods around it. ``aspect`` draws for a can whose label
is that much taller relative to its circumference than the built can's, then resizes, so nothing looks stretched.
"""

from __future__ import annotations

import colorsys
from functools import lru_cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from deformsim.blender.part.can_label import _barcode, _brand, _nutrition, make_label
from deformsim.sampling import AppearanceParams, CanDesign

SILVER = np.array([0.86, 0.87, 0.89])
_WORDS = ("natural flavours", "carbonated water", "sugar", "citric acid", "contains caffeine", "no preservatives",
          "best before see base", "serve chilled", "please recycle", "made with real fruit", "since 1987",
          "limited edition", "zero sugar", "sparkling", "refreshing taste", "store in a cool dry place",
          "ingredients", "acidity regulator", "sweeteners", "colour caramel", "vitamin c", "low calorie")


def make_artwork(design: CanDesign, look: AppearanceParams, width: int = 512, height: int = 256,
                 aspect: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """``(rgba, metal)``: float32 arrays of shape ``(height, width, 4)`` and ``(height, width)`` in [0, 1], row 0 =
    top of the side wall."""
    h = max(8, int(round(height * aspect)))
    if look.style == "photo":
        rgb, metal = _photo(design, look, width, h)
    elif look.style in ("designer", "bare"):
        rgb, metal = _designer(design, look, width, h)
    else:
        rgb, metal = make_label(design, width, h)[..., :3], np.zeros((h, width), np.float32)
    if h != height:
        rgb = np.asarray(Image.fromarray(_u8(rgb)).resize((width, height), Image.BILINEAR), np.float32) / 255
        metal = np.asarray(Image.fromarray(_u8(metal)).resize((width, height), Image.BILINEAR), np.float32) / 255
    rgba = np.concatenate([rgb.astype(np.float32), np.ones((height, width, 1), np.float32)], axis=2)
    return rgba, metal.astype(np.float32)


def _u8(a: np.ndarray) -> np.ndarray:
    return (np.clip(a, 0, 1) * 255 + 0.5).astype(np.uint8)


def _hsv(h: float, s: float, v: float) -> np.ndarray:
    return np.array(colorsys.hsv_to_rgb(h % 1, min(max(s, 0), 1), min(max(v, 0), 1)))


class _Canvas:
    """Colour and metal mask; each element is an alpha (coverage) laid over both."""

    def __init__(self, rgb: np.ndarray, metal: np.ndarray):
        self.rgb, self.metal = rgb, metal
        self.h, self.w = metal.shape

    def put(self, alpha: np.ndarray, colour: np.ndarray, metal: float = 0.0) -> None:
        a = np.clip(alpha, 0, 1)
        self.rgb = self.rgb * (1 - a[..., None]) + np.asarray(colour) * a[..., None]
        self.metal = self.metal * (1 - a) + metal * a

    def layer(self) -> tuple[Image.Image, ImageDraw.ImageDraw]:
        img = Image.new("L", (self.w, self.h), 0)
        return img, ImageDraw.Draw(img)

    def put_layer(self, img: Image.Image, colour: np.ndarray, metal: float = 0.0) -> None:
        self.put(np.asarray(img, np.float32) / 255, colour, metal)


def _designer(design: CanDesign, look: AppearanceParams, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(look.seed)
    base = _hsv(design.hue, design.saturation, design.value)
    accent = _hsv(design.accent_hue, 0.75 + 0.25 * design.saturation, 0.9)
    third = _hsv(design.hue + rng.choice([0.08, -0.08, 0.5]), design.saturation * 0.8, min(1, design.value + 0.25))
    dark = _hsv(design.hue, 0.6, 0.12)
    foil = SILVER if rng.uniform() < 0.6 else _hsv(design.accent_hue, 0.35, 0.85)  # silver or tinted foil
    bare = look.style == "bare"
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h)[:, None] + 0.5) / h
    if bare:
        c = _Canvas(np.broadcast_to(SILVER, (h, w, 3)).copy(), np.ones((h, w), np.float32))
    else:
        kind = rng.integers(3)
        second = base * rng.uniform(0.35, 0.7) if rng.uniform() < 0.5 else third
        if kind == 0:  # top to bottom
            t = np.broadcast_to(v, (h, w))
        elif kind == 1:  # around the can: whole periods
            t = np.broadcast_to(0.5 - 0.5 * np.cos(2 * np.pi * int(rng.integers(1, 3)) * u + rng.uniform(0, 6.3)), (h, w))
        else:  # from a bright centre at the front
            du = np.minimum(np.abs(u - 0.3), 1 - np.abs(u - 0.3))
            t = np.clip(np.hypot(du[None, :] * 2.2, (v - 0.5) * 1.1), 0, 1)
        t = t ** rng.uniform(0.6, 1.6)
        c = _Canvas(base * (1 - t[..., None]) + second * t[..., None], np.zeros((h, w), np.float32))

    ink = [accent, third, dark, np.ones(3)]
    metallic = look.metallic or bare

    def colour() -> tuple[np.ndarray, float]:
        if metallic and not bare and rng.uniform() < 0.4:
            return foil, 1.0
        return ink[int(rng.integers(len(ink)))], 0.0

    for _ in range(int(rng.integers(1, 3) if bare else rng.integers(3, 7))):
        _GRAPHICS[int(rng.integers(len(_GRAPHICS)))](c, rng, u, v, *colour())
    _logo(c, rng, design, colour, dark)
    panel = rng.uniform() < 0.7
    _text_blocks(c, rng, dark if bare or float(np.dot(base, (0.3, 0.59, 0.11))) > 0.55 else np.ones(3), panel)
    if panel:
        img = Image.fromarray(_u8(c.rgb))
        draw = ImageDraw.Draw(img)
        _nutrition(draw, (20, 20, 20), w, h)
        _barcode(draw, rng, w, h)
        panel = np.zeros((h, w), np.float32)
        panel[int(0.18 * h):int(0.86 * h) + 4, int(0.6 * w) - 3:int(0.76 * w) + 4] = 1
        c.rgb = np.asarray(img, np.float32) / 255
        c.metal = c.metal * (1 - panel)
    return c.rgb, c.metal


def _pinstripes(c: _Canvas, rng, u, v, colour, metal) -> None:
    for _ in range(int(rng.integers(2, 7))):
        y = rng.uniform(0.04, 0.96)
        half = rng.uniform(0.6, 2.0) / c.h
        c.put(np.broadcast_to(np.clip((half - np.abs(v - y)) * c.h + 0.5, 0, 1), (c.h, c.w)), colour, metal)


def _halftone(c: _Canvas, rng, u, v, colour, metal) -> None:
    cols = int(rng.integers(40, 120))
    pitch = c.w / cols
    y0, y1 = sorted(rng.uniform(0.05, 0.95, 2))
    y1 = max(y1, y0 + 0.15)
    fu = (u * cols) % 1 - 0.5
    rows = np.arange(c.h)[:, None] / pitch
    fv = (rows + 0.5 * (np.floor(u * cols) % 2)) % 1 - 0.5  # staggered rows
    grow = np.clip((v - y0) / (y1 - y0), 0, 1)
    if rng.uniform() < 0.5:
        grow = 1 - grow
    radius = 0.5 * grow * (v < y1 + 0.1) * (v > y0 - 0.1)
    d = np.hypot(fu[None, :], fv) * pitch
    c.put(np.clip(radius * pitch - d + 0.5, 0, 1), colour, metal)


def _hatching(c: _Canvas, rng, u, v, colour, metal) -> None:
    y0 = rng.uniform(0.05, 0.7)
    y1 = y0 + rng.uniform(0.08, 0.3)
    n = int(rng.integers(30, 90))  # whole periods around the can
    slope = rng.uniform(-1.5, 1.5) * n * c.h / c.w
    phase = (u[None, :] * n + v * slope) % 1
    line = np.clip((0.18 - np.abs(phase - 0.5) / 2.8) * 6, 0, 1)
    band = np.clip((np.minimum(v - y0, y1 - v)) * c.h, 0, 1)
    c.put(line * band, colour, metal)


def _ribbon(c: _Canvas, rng, u, v, colour, metal) -> None:
    mid = rng.uniform(0.15, 0.85) + rng.uniform(0.03, 0.15) * np.sin(2 * np.pi * int(rng.integers(1, 4)) * u
                                                                    + rng.uniform(0, 6.3))
    half = rng.uniform(0.01, 0.06)
    c.put(np.clip((half - np.abs(v - mid[None, :])) * c.h + 0.5, 0, 1), colour, metal)


def _rays(c: _Canvas, rng, u, v, colour, metal) -> None:
    du = (u - 0.3 + 0.5) % 1 - 0.5  # around the front, wrapped
    x, y = du[None, :] * c.w, (v - 0.5) * c.h
    ang = np.arctan2(y, x)
    n = int(rng.integers(12, 36))
    ray = np.clip((np.cos(ang * n) - 0.3) * 3, 0, 1)
    fade = np.clip(1 - np.hypot(x, y) / (c.h * rng.uniform(0.5, 1.2)), 0, 1)
    c.put(ray * fade * rng.uniform(0.4, 1.0), colour, metal)


def _confetti(c: _Canvas, rng, u, v, colour, metal) -> None:
    img, draw = c.layer()
    for _ in range(int(rng.integers(15, 60))):
        x, y, r = rng.uniform(0, c.w), rng.uniform(0, c.h), rng.uniform(1.5, c.h * 0.03)
        for dx in (-c.w, 0, c.w):  # drawn wrapped: seamless
            if rng.uniform() < 0.5:
                draw.ellipse((x + dx - r, y - r, x + dx + r, y + r), fill=255)
            else:
                draw.polygon([(x + dx, y - r), (x + dx + r, y + r), (x + dx - r, y + r)], fill=255)
    c.put_layer(img, colour, metal)


_GRAPHICS = (_pinstripes, _halftone, _hatching, _ribbon, _rays, _confetti)


def _logo(c: _Canvas, rng, design: CanDesign, colour, dark) -> None:
    """A badge (disk, ring or shield) at the front with the brand word on it, or the word alone."""
    cx, cy, r = 0.3 * c.w, c.h * rng.uniform(0.4, 0.6), c.h * rng.uniform(0.22, 0.36)
    if rng.uniform() < 0.65:
        img, draw = c.layer()
        if rng.uniform() < 0.5:
            draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=255)
        else:
            draw.polygon([(cx - r, cy - r), (cx + r, cy - r), (cx + r, cy + 0.3 * r), (cx, cy + r),
                          (cx - r, cy + 0.3 * r)], fill=255)
        col, metal = colour()
        c.put_layer(img, col, metal)
        ring, rd = c.layer()
        rd.ellipse((cx - r * 1.08, cy - r * 1.08, cx + r * 1.08, cy + r * 1.08), outline=255,
                   width=max(1, int(r * 0.05)))
        col, metal = colour()
        c.put_layer(ring, col, metal)
    word_img = Image.fromarray(_u8(c.rgb))
    light = float(np.dot(c.rgb[int(cy), int(cx)], (0.3, 0.59, 0.11))) > 0.55
    ink = (25, 25, 30) if light else (250, 250, 245)
    outline = tuple(int(x) for x in _u8(dark if not light else np.ones(3)))
    before = np.asarray(word_img, np.float32) / 255
    _brand(word_img, design.word, ink, outline, bool(rng.uniform() < 0.3), c.w, c.h)
    after = np.asarray(word_img, np.float32) / 255
    changed = np.any(np.abs(after - before) > 1e-3, axis=2).astype(np.float32)
    c.rgb, c.metal = after, c.metal * (1 - changed)


def _text_blocks(c: _Canvas, rng, ink: np.ndarray, panel: bool) -> None:
    """One to three blocks of small text lines (ingredients, claims) and the volume, clear of the front (and of the
    nutrition panel when there is one); a line that runs past the seam goes on at u = 0."""
    img, draw = c.layer()
    size = max(5, int(c.h / rng.uniform(28, 40)))
    font = ImageFont.load_default(size=size)
    for _ in range(int(rng.integers(1, 4))):
        x = c.w * (rng.uniform(0.78, 0.86) if panel else rng.uniform(0.45, 0.8))
        y = c.h * rng.uniform(0.08, 0.6)
        for i in range(int(rng.integers(2, 7))):
            text = _WORDS[int(rng.integers(len(_WORDS)))]
            for dx in (0, -c.w):
                draw.text((x + dx, y + i * size * 1.25), text.upper() if i == 0 else text, font=font, fill=255)
    big = ImageFont.load_default(size=max(6, int(c.h / 14)))
    draw.text((c.w * 0.22, c.h * 0.86), f"{int(rng.choice([250, 330, 355, 440, 473, 500, 568]))} ml", font=big,
              fill=255)
    c.put_layer(img, ink, 0.0)


@lru_cache(maxsize=4)
def _photo_pixels(path: str) -> np.ndarray:
    """A photo as float RGB, at most 1024 px on its longer side (a few cached: a worker reuses them)."""
    with Image.open(path) as im:
        im = im.convert("RGB")
        im.thumbnail((1024, 1024))
        return np.asarray(im, np.float32) / 255


def _photo(design: CanDesign, look: AppearanceParams, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """A crop of the photo with the label's aspect (left, top and zoom from ``look.crop``), sometimes the word on it."""
    px = _photo_pixels(look.photo)
    ph, pw = px.shape[:2]
    left, top, zoom = look.crop
    cw = min(pw, ph * w / h) / zoom  # the largest crop of the label's aspect, zoomed in
    ch = cw * h / w
    x0, y0 = left * (pw - cw), top * (ph - ch)
    img = Image.fromarray(_u8(px)).resize((w, h), Image.BILINEAR, box=(x0, y0, x0 + cw, y0 + ch))
    if np.random.default_rng(look.seed).uniform() < 0.5:
        _brand(img, design.word, (250, 250, 245), (20, 20, 25), False, w, h)
    return np.asarray(img, np.float32) / 255, np.zeros((h, w), np.float32)
