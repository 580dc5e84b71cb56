"""What an export reads: one variant's images, labels and, where they line up with its pictures, part masks.

The masks of a composited variant are its own moved maps (``variants/NAME/{mask,region}``); the render's maps
(or, without dense maps, the render's alpha) fit a variant only when its pictures keep the render's geometry:
``black``, ``green``, or a composite that was neither framed nor flipped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from deformsim.dataset.dense import read_mask
from deformsim.dataset.layout import RENDER_KINDS, Layout
from deformsim.dataset.paths import check_image, dataset_files
from deformsim.dataset.variants import has_own_maps, list_variants, variant_table
from deformsim.errors import UserError
from deformsim.schema import shown

SEVERITY = ("max_disp_mm", "visible_disp_mm", "region_fraction")
FILES = {"path": "image", "mask_path": "mask", "region_path": "region map"}  # the file columns an export reads


def default_variant(root: Path) -> str:
    """The first composited variant (by name), else ``black``."""
    made = [v for v in list_variants(root) if v not in RENDER_KINDS]
    return made[0] if made else "black"


def _keeps_geometry(table: pd.DataFrame, variant: str) -> bool:
    """Do the variant's pictures keep the render's geometry (so the render's maps or alpha fit them)?"""
    if variant in RENDER_KINDS:
        return True
    flipped = "part_flip" in table.columns and bool(table["part_flip"].any())
    return "frame_side" not in table.columns and not flipped


def export_table(root: Path, variant: str) -> pd.DataFrame:
    """Columns ``id, label, y, path``, ``mask_src`` (``dense``, ``alpha`` or ``none``), and when masks fit:
    ``mask_path`` (a 0/255 map, or the RGBA render whose alpha is the mask) and ``region_path`` (dense only); the
    paths resolved, each checked to be an image inside the dataset.

    A :class:`UserError` for an unknown variant, a missing image, a file outside the dataset or one that does not
    open as an image, before anything is written.
    """
    layout = Layout(Path(root).absolute())  # the table's paths absolute too
    table = variant_table(layout.root, variant)
    if table.empty:
        raise UserError(f"variant '{variant}' of {root} has no images")
    if "mask" in table.columns and (has_own_maps(root, variant) or _keeps_geometry(table, variant)):
        table["mask_src"] = "dense"
        table["mask_path"], table["region_path"] = table["mask"], table["region"]
    elif "rgba" in table.columns and _keeps_geometry(table, variant):
        table["mask_src"] = "alpha"
        table["mask_path"] = table["rgba"]
    else:
        table["mask_src"] = "none"
    table = table.sort_values("id").reset_index(drop=True)
    _check_files(table, layout.root, variant)
    return table


def _check_files(table: pd.DataFrame, root: Path, variant: str) -> None:
    """Resolve every file column of ``table`` in place: inside ``root``, there, and an image that opens."""
    columns = [c for c in FILES if c in table.columns]
    for col in columns:
        rows = (f"variant '{variant}' row {shown(i, 40)}, {FILES[col]}" for i in table["id"])
        table[col] = dataset_files(root, table[col], rows)
    gone = [p for col in columns for p in table[col] if not Path(p).exists()]
    if gone:
        raise UserError(f"{len(gone)} file(s) of variant '{variant}' missing, e.g. {shown(gone[0], 200)}")
    for col in columns:
        for i, p in zip(table["id"], table[col]):
            check_image(p, f"variant '{variant}' row {shown(i, 40)}, {FILES[col]}")


def part_mask(row) -> np.ndarray:
    """The part's mask (bool) of a row of :func:`export_table`: the dense mask, or render alpha >= 0.5."""
    if row.mask_src == "dense":
        return read_mask(row.mask_path)
    with Image.open(row.mask_path) as im:
        return np.asarray(im.getchannel("A")) >= 128


def image_size(path: str) -> tuple[int, int]:
    """``(width, height)`` from the file's header."""
    with Image.open(path) as im:
        return im.size


def families(row) -> list[str]:
    value = getattr(row, "families", "")
    return [f for f in str(value).split(",") if f] if isinstance(value, str) else []
