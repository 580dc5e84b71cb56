"""Contact sheets: a grid of images with their labels, for a person to judge a dataset at a glance."""

from __future__ import annotations

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw, ImageFont

from deformsim.atomic import atomic_path
from deformsim.dataset.images import CLASSES, open_rgb
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import read_manifest

COLORS = dict(zip(CLASSES, ((46, 160, 67), (207, 34, 46))))  # green, red


def pick(df: pd.DataFrame, count: int, seed: int) -> pd.DataFrame:
    """Up to ``count`` rows, half of each label where possible, in a seeded random order."""
    rng = np.random.default_rng(seed)
    parts = [g.iloc[rng.permutation(len(g))[: (count + 1) // 2]] for _, g in df.groupby("label")]
    both = pd.concat(parts)
    return both.iloc[rng.permutation(len(both))[:count]]


def grid(images: list[Image.Image], captions: list[tuple[str, tuple]], tile: int = 160, cols: int = 4) -> Image.Image:
    """Tile images (resized to ``tile``) with a coloured caption bar under each."""
    bar = max(14, tile // 8)
    rows = max(1, -(-len(images) // cols))
    sheet = Image.new("RGB", (cols * tile, rows * (tile + bar)), (255, 255, 255))
    font = ImageFont.load_default(size=max(8, bar - 6))
    draw = ImageDraw.Draw(sheet)
    for k, (img, (text, color)) in enumerate(zip(images, captions)):
        x, y = (k % cols) * tile, (k // cols) * (tile + bar)
        sheet.paste(img.convert("RGB").resize((tile, tile), Image.LANCZOS), (x, y))
        draw.rectangle([x, y + tile, x + tile - 1, y + tile + bar - 1], fill=color)
        draw.text((x + 4, y + tile + 1), text, fill=(255, 255, 255), font=font)
    return sheet


def _on_grey(path) -> Image.Image:
    rgba = Image.open(path).convert("RGBA")
    bg = Image.new("RGBA", rgba.size, (200, 200, 200, 255))
    return Image.alpha_composite(bg, rgba)


def contact_sheet(layout: Layout, count: int, seed: int, column: str = "rgba") -> None:
    """Write ``preview.png``: random images of the dataset (alpha over grey) with their labels."""
    df = pick(read_manifest(layout.root), count, seed)
    images = [_on_grey(layout.root / p) if column == "rgba" else open_rgb(layout.root / p) for p in df[column]]
    captions = [(f"{r.label}  {r.id}", COLORS[r.label]) for r in df.itertuples()]
    sheet = grid(images, captions, cols=min(4, max(1, len(images))))
    with atomic_path(layout.preview) as tmp:
        sheet.save(tmp, format="PNG")
