"""Printed marks on a finish (spec ``print``; pure numpy + PIL, no Blender).

:func:`make_print` draws a sample's marks as an ink coverage mask over the square that each side of the part's box
maps to (Blender's generated coordinates, box-projected): on the end of an upright round part the centre of the
square is the axis and its inscribed circle the rim. Styles: ``ring`` (words around the centre, like a lid's
printed ring), ``lines`` (a few lines of small text) and ``dots`` (an ink-jet dot-matrix code: a batch and date).
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from deformsim.sampling import PrintParams

SPAN = 0.6  # the widest text of lines and dots, as a share of the side (the end's diameter on a round part)
_WORDS = ("easy open", "best before", "net wt 400 g", "keep refrigerated after opening", "product of", "recycle",
          "peeled tomatoes", "baked beans", "sweet corn", "chick peas", "in tomato sauce", "no added sugar",
          "store in a cool dry place", "once opened", "ingredients", "batch", "packed by", "drained weight 240 g")


def make_print(p: PrintParams, size: int = 512) -> np.ndarray:
    """The ink coverage of ``p``: float32 ``(size, size)`` in [0, 1]."""
    rng = np.random.default_rng(p.seed)
    img = {"ring": _ring, "lines": _lines, "dots": _dots}[p.style](rng, size)
    return np.asarray(img, np.float32) / 255


def _font(px: float) -> ImageFont.ImageFont:
    return ImageFont.load_default(size=max(4, int(px)))


def _phrase(rng: np.random.Generator) -> str:
    return _WORDS[int(rng.integers(len(_WORDS), size=1)[0])].upper()


def _code(rng: np.random.Generator) -> str:
    day, month, year = int(rng.integers(1, 29)), int(rng.integers(1, 13)), int(rng.integers(2026, 2031))
    letters = "".join(chr(65 + int(i)) for i in rng.integers(26, size=2))
    return f"{day:02d}.{month:02d}.{year} {letters}{int(rng.integers(1000, 9999))}"


def _ring(rng: np.random.Generator, size: int) -> Image.Image:
    """Words set in a strip, wrapped around the centre between two radii (a lid's printed ring)."""
    outer = rng.uniform(0.25, 0.38) * size
    band = rng.uniform(0.045, 0.08) * size
    circumference = int(2 * np.pi * outer)
    strip = Image.new("L", (circumference, max(4, int(band))), 0)
    draw = ImageDraw.Draw(strip)
    font = _font(band * 0.8)
    x = 0.0
    while x < circumference * 0.9:
        text = _phrase(rng) + "  *  "
        draw.text((x, band * 0.1), text, font=font, fill=255)
        x += draw.textlength(text, font=font)
    s = np.asarray(strip, np.float32)
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    dx, dy = xx - size / 2, yy - size / 2
    r = np.hypot(dx, dy)
    turn = (np.arctan2(dy, dx) / (2 * np.pi) + rng.uniform()) % 1
    row = ((outer - r) / band * s.shape[0]).astype(int)
    col = np.minimum((turn * circumference).astype(int), circumference - 1)
    inside = (row >= 0) & (row < s.shape[0])
    out = np.where(inside, s[np.clip(row, 0, s.shape[0] - 1), col], 0)
    return Image.fromarray(out.astype(np.uint8))


def _lines(rng: np.random.Generator, size: int) -> Image.Image:
    """Two to four lines of text near the centre, at most :data:`SPAN` of the side wide, turned by a drawn angle."""
    img = Image.new("L", (size, size), 0)
    draw = ImageDraw.Draw(img)
    n = int(rng.integers(2, 5))
    texts = [_phrase(rng) for _ in range(n - 1)] + [_code(rng)]
    px = rng.uniform(0.035, 0.06) * size
    px *= min(1.0, SPAN * size / max(draw.textlength(t, font=_font(px)) for t in texts))
    font = _font(px)
    top = size / 2 - n * px * 0.65
    for i, text in enumerate(texts):
        draw.text(((size - draw.textlength(text, font=font)) / 2, top + i * px * 1.3), text, font=font, fill=255)
    return _turned(img, rng)


def _dots(rng: np.random.Generator, size: int) -> Image.Image:
    """One or two lines of an ink-jet code, 60-100 % of :data:`SPAN` wide: each lit pixel of a 7-pixel-high font becomes
    a round dot."""
    lines = [_code(rng) for _ in range(int(rng.integers(1, 3)))]
    font = _font(9)
    glyphs = Image.new("L", (160, 12 * len(lines) + 2), 0)
    draw = ImageDraw.Draw(glyphs)
    for i, text in enumerate(lines):
        draw.text((1, 1 + 12 * i), text, font=font, fill=255)
    on = np.argwhere(np.asarray(glyphs) > 128)
    img = Image.new("L", (size, size), 0)
    if len(on):
        pitch = rng.uniform(0.6, 1.0) * SPAN * size / (np.ptp(on[:, 1]) + 1)
        centre = (on.max(0) + on.min(0)) / 2
        dot = pitch * 0.45
        draw = ImageDraw.Draw(img)
        for y, x in (on - centre) * pitch + size / 2:
            draw.ellipse((x - dot, y - dot, x + dot, y + dot), fill=255)
    return _turned(img, rng)


def _turned(img: Image.Image, rng: np.random.Generator) -> Image.Image:
    """``img`` turned about its centre by a drawn angle and moved off centre by up to a twentieth of its side."""
    shift = rng.uniform(-0.05, 0.05, size=2) * img.size[0]
    return img.rotate(float(rng.uniform(0, 360)), Image.BILINEAR, translate=tuple(shift))
