"""Contact sheets: a grid of images with their labels, for a person to judge a dataset at a glance."""

from __future__ import annotations

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw, ImageFont

from deformsim.atomic import atomic_path
from deformsim.dataset.dense import read_deform_mm, read_depth_mm, read_mask
from deformsim.dataset.images import CLASSES, open_rgb
from deformsim.dataset.layout import DENSE_KINDS, Layout
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import UserError

COLORS = dict(zip(CLASSES, ((46, 160, 67), (207, 34, 46))))  # green, red
MAP_GREY = (90, 90, 90)


def pick(df: pd.DataFrame, count: int, seed: int) -> pd.DataFrame:
    """Up to ``count`` rows, half of each label where possible, in a seeded random order."""
    rng = np.random.default_rng(seed)
    parts = [g.iloc[rng.permutation(len(g))[: (count + 1) // 2]] for _, g in df.groupby("label")]
    both = pd.concat(parts)
    return both.iloc[rng.permutation(len(both))[:count]]


MIN_FONT = 7  # pixels: a caption never gets a smaller font


def caption(text: str, width: int, size: int) -> tuple[str, ImageFont.FreeTypeFont]:
    """``text`` and the largest font of at most ``size`` px (not under :data:`MIN_FONT`) it fits ``width`` px in;
    a text too long even then keeps its start and end around an ellipsis."""
    for px in range(size, MIN_FONT - 1, -1):
        font = ImageFont.load_default(size=px)
        if font.getlength(text) <= width:
            return text, font
    keep = len(text)
    while keep > 2 and font.getlength(f"{text[:-(-keep // 2)]}…{text[len(text) - keep // 2:]}") > width:
        keep -= 1
    return f"{text[:-(-keep // 2)]}…{text[len(text) - keep // 2:]}", font


def grid(images: list[Image.Image], captions: list[tuple[str, tuple]], tile: int = 160, cols: int = 4) -> Image.Image:
    """Tile images (resized to ``tile``) with a coloured caption bar under each, its text whole where it fits."""
    bar = max(14, tile // 8)
    rows = max(1, -(-len(images) // cols))
    sheet = Image.new("RGB", (cols * tile, rows * (tile + bar)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, (img, (text, color)) in enumerate(zip(images, captions)):
        x, y = (k % cols) * tile, (k // cols) * (tile + bar)
        sheet.paste(img.convert("RGB").resize((tile, tile), Image.LANCZOS), (x, y))
        draw.rectangle([x, y + tile, x + tile - 1, y + tile + bar - 1], fill=color)
        shown, font = caption(text, tile - 8, max(8, bar - 6))
        draw.text((x + 4, y + tile + 1), shown, fill=(255, 255, 255), font=font)
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


def _scaled(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``values`` on the part mapped to 0..1 (0 off the part)."""
    if not mask.any():
        return np.zeros(values.shape, np.float32)
    lo, hi = float(values[mask].min()), float(values[mask].max())
    return np.where(mask, (values - lo) / (hi - lo) if hi > lo else 0.0, 0.0).astype(np.float32)


def map_image(kind: str, path) -> Image.Image:
    """A dense map as a picture: masks in white, depth near-bright, normals as RGB, deformation in heat colours."""
    if kind in ("mask", "region"):
        return Image.fromarray(read_mask(path).astype(np.uint8) * 255)
    if kind == "normal":
        return open_rgb(path)
    if kind == "depth":
        depth = read_depth_mm(path)
        on = depth > 0
        return Image.fromarray(np.where(on, 255 - 215 * _scaled(depth, on), 0).astype(np.uint8))
    t = np.clip(read_deform_mm(path) / 3.0, 0, 1)  # 3 mm and more: full heat
    heat = np.stack([np.clip(2 * t, 0, 1), np.clip(2 * t - 1, 0, 1), np.zeros_like(t)], axis=-1)
    return Image.fromarray((heat * 255).astype(np.uint8))


def variant_sheet(df: pd.DataFrame, count: int, seed: int, dense: bool) -> Image.Image:
    """Random images of a variant table (``variants.variant_table``) with their labels; with ``dense``, one row per
    image: the image, then its mask, depth, normal, deform and region maps."""
    rows = pick(df, count, seed)
    if not dense:
        images = [open_rgb(p) for p in rows["path"]]
        captions = [(f"{r.label}  {r.id}", COLORS[r.label]) for r in rows.itertuples()]
        return grid(images, captions, cols=min(4, max(1, len(images))))
    missing = [k for k in DENSE_KINDS if k not in df.columns]
    if missing:
        raise UserError(f"the dataset has no dense maps ({', '.join(missing)}): generate it with render.dense on")
    images, captions = [], []
    for r in rows.itertuples():
        images.append(open_rgb(r.path))
        captions.append((f"{r.label}  {r.id}", COLORS[r.label]))
        for kind in DENSE_KINDS:
            images.append(map_image(kind, getattr(r, kind)))
            captions.append((kind, MAP_GREY))
    return grid(images, captions, cols=1 + len(DENSE_KINDS))
