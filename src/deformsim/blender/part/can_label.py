"""Procedural printed soda-can labels (pure numpy + PIL, no Blender).

The label wraps around the can: column ``x`` is the angle ``u = x / width`` and row 0 is the top of the
side wall. Everything that crosses the wrap (bands, waves) has a whole number of periods around the can, and
the printed blocks (brand word, nutrition panel, barcode) stay clear of the seam at ``u = 0``.
"""

from __future__ import annotations

import colorsys

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from deformsim.errors import UserError
from deformsim.sampling import CanDesign

_NUTRITION = ("Nutrition Facts", "Serving 355 ml", "Calories 140", "Total Fat 0g", "Sodium 45mg",
              "Total Carb 39g", "Sugars 39g", "Protein 0g", "Caffeine 34mg")


def make_label(design: CanDesign, width: int = 1024, height: int = 512) -> np.ndarray:
    """Render ``design`` as a float32 RGBA array of shape ``(height, width, 4)`` in [0, 1], row 0 = top."""
    if width < 16 or height < 8:
        raise UserError(f"label size {width}x{height} is too small (need at least 16x8 pixels)")
    rng = np.random.default_rng(design.band_seed)
    base = np.array(colorsys.hsv_to_rgb(design.hue % 1, design.saturation, design.value))
    accent = np.array(colorsys.hsv_to_rgb(design.accent_hue % 1, 0.75 + 0.25 * design.saturation, 0.9))
    rgb = np.broadcast_to(base, (height, width, 3)).copy()
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height)[:, None] + 0.5) / height
    for _ in range(max(0, design.bands)):
        centre = rng.uniform(0.08, 0.92)
        half = rng.uniform(0.015, 0.07)
        amp = rng.uniform(0.0, 0.12) * rng.integers(0, 2)  # half the bands straight, half waves
        cycles = int(rng.integers(1, 4))  # whole periods around the can: seamless at the wrap
        phase = rng.uniform(0, 2 * np.pi)
        mid = centre + amp * np.sin(2 * np.pi * cycles * u + phase)
        dist = np.abs(v - mid[None, :])
        mask = np.clip((half - dist) * height + 0.5, 0, 1)[..., None]  # one-pixel antialiased edge
        colour = accent if rng.uniform() < 0.75 else np.ones(3)
        rgb = rgb * (1 - mask) + colour * mask
    img = Image.fromarray((rgb * 255 + 0.5).astype(np.uint8), "RGB")
    draw = ImageDraw.Draw(img)
    light = float(np.dot(base, (0.299, 0.587, 0.114))) > 0.55
    ink = (25, 25, 30) if light else (250, 250, 245)
    _brand(img, design.word, ink, _rgb8(accent), bool(rng.uniform() < 0.5), width, height)
    _nutrition(draw, ink, width, height)
    _barcode(draw, rng, width, height)
    out = np.asarray(img, dtype=np.float32) / 255.0
    return np.concatenate([out, np.ones((height, width, 1), np.float32)], axis=2)


def _rgb8(c: np.ndarray) -> tuple[int, int, int]:
    return tuple(int(x * 255 + 0.5) for x in c)


def _brand(img: Image.Image, word: str, ink, outline, vertical: bool, width: int, height: int) -> None:
    """The big brand word, centred at u = 0.3 (front of the can), upright or running up the can."""
    word = word or "SODA"
    box_w, box_h = (int(height * 0.85), int(width * 0.2)) if vertical else (int(width * 0.36), int(height * 0.5))
    size = max(8, box_h)
    font = ImageFont.load_default(size=size)
    stroke = max(1, size // 25)
    left, top, right, bottom = font.getbbox(word, stroke_width=stroke)
    scale = min(box_w / max(1, right - left), box_h / max(1, bottom - top))
    font = ImageFont.load_default(size=max(8, int(size * scale)))
    left, top, right, bottom = font.getbbox(word, stroke_width=stroke)
    tile = Image.new("L", (right - left, bottom - top), 0)
    edge = Image.new("L", tile.size, 0)
    ImageDraw.Draw(edge).text((-left, -top), word, font=font, fill=255, stroke_width=stroke)
    ImageDraw.Draw(tile).text((-left, -top), word, font=font, fill=255)
    if vertical:  # reads bottom-to-top, as on many cans
        tile, edge = tile.rotate(90, expand=True), edge.rotate(90, expand=True)
    x = int(0.3 * width - tile.width / 2)
    y = int(0.5 * height - tile.height / 2)
    img.paste(outline, (x, y), edge)
    img.paste(ink, (x, y), tile)


def _nutrition(draw: ImageDraw.ImageDraw, ink, width: int, height: int) -> None:
    """Small nutrition-fact lines on a white panel around u = 0.68."""
    x0, x1 = int(0.6 * width), int(0.76 * width)
    y0, y1 = int(0.18 * height), int(0.62 * height)
    draw.rectangle((x0, y0, x1, y1), fill=(245, 245, 240))
    line = (y1 - y0) / (len(_NUTRITION) + 1)
    font = ImageFont.load_default(size=max(4, int(line * 0.7)))
    for i, text in enumerate(_NUTRITION):
        y = y0 + line * (i + 0.5)
        draw.text((x0 + line * 0.3, y), text, font=font, fill=(20, 20, 20))
        draw.line((x0 + 2, y + line * 0.95, x1 - 2, y + line * 0.95), fill=(40, 40, 40), width=1)
    draw.rectangle((x0, y0, x1, y1), outline=ink, width=max(1, height // 200))


def _barcode(draw: ImageDraw.ImageDraw, rng: np.random.Generator, width: int, height: int) -> None:
    """A barcode-like block of random bar widths below the nutrition panel."""
    x0, x1 = int(0.62 * width), int(0.74 * width)
    y0, y1 = int(0.68 * height), int(0.86 * height)
    draw.rectangle((x0 - 3, y0 - 3, x1 + 3, y1 + 3), fill=(255, 255, 255))
    x = x0
    unit = max(1, (x1 - x0) // 90)
    while x < x1:
        w = unit * int(rng.integers(1, 4))
        draw.rectangle((x, y0, min(x + w - 1, x1), y1), fill=(0, 0, 0))
        x += w + unit * int(rng.integers(1, 4))
