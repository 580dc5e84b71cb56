"""COCO instances layout: the pictures and one JSON of part instances with RLE masks and severity attributes.

    OUT/images/ID.png
    OUT/annotations/instances.json

Categories ``intact`` (1) and ``deformed`` (2), both of supercategory ``part``. Each image whose part is visible has
one annotation: the part's mask as compressed RLE (``counts`` a string), its box ``[x, y, w, h]``, its pixel area,
``iscrowd`` 0 and ``attributes`` {label, deformed, families, max_disp_mm, visible_disp_mm, region_fraction} (the
severities the dataset records). Image entries carry ``deformsim_id`` and ``sample`` besides the COCO fields.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from pycocotools import mask as mask_utils

from deformsim.atomic import write_json
from deformsim.dataset.dense import mask_bbox
from deformsim.errors import UserError
from deformsim.export.files import place
from deformsim.export.source import SEVERITY, families, image_size, part_mask

CATEGORIES = [{"id": 1, "name": "intact", "supercategory": "part"}, {"id": 2, "name": "deformed", "supercategory": "part"}]
INSTANCES = "annotations/instances.json"

README = """deformsim export, COCO instances: images/ and annotations/instances.json (masks from {masks}).

pycocotools:   COCO("{out}/annotations/instances.json")
torchvision:   torchvision.datasets.CocoDetection("{out}/images", "{out}/annotations/instances.json")
Categories: 1 intact, 2 deformed (supercategory part). Each visible part is one annotation: an RLE mask, its box
[x, y, w, h], its area, and attributes {{label, deformed, families, max_disp_mm, visible_disp_mm, region_fraction}}.
Views of one rendered part share the image field 'sample': split by it to keep them on one side of a split.
"""


def _attributes(row, columns) -> dict:
    out = {"label": row.label, "deformed": bool(row.y), "families": families(row)}
    out.update({c: float(getattr(row, c)) for c in SEVERITY if c in columns})
    return out


def require_masks(table: pd.DataFrame) -> None:
    """A :class:`UserError` unless every image has a part mask that fits it."""
    if (table["mask_src"] == "none").any():
        raise UserError("coco needs part masks, but this variant's pictures were framed or flipped and the dataset has "
                        "no dense maps that follow them: export variant black or green, or render with render.dense: true")


def write_coco(table: pd.DataFrame, out: Path, final: Path, bar, copy: bool = False) -> dict:
    """Fill ``out`` (to become ``final``; hard links unless ``copy``; masks checked by :func:`require_masks`); the
    summary and the README's text."""
    cat = {c["name"]: c["id"] for c in CATEGORIES}
    images, annotations, linked = [], [], 0
    for n, row in enumerate(table.itertuples(index=False), start=1):
        file = f"images/{row.id}{Path(row.path).suffix}"
        mask = part_mask(row)
        w, h = image_size(row.path)
        if mask.shape != (h, w):
            raise UserError(f"mask {row.mask_path} is {mask.shape[1]}x{mask.shape[0]}, its image {row.path} {w}x{h}")
        linked += place(row.path, out / file, copy)
        image = {"id": n, "file_name": file, "width": w, "height": h, "deformsim_id": row.id}
        images.append(image | ({"sample": int(row.sample)} if "sample" in table.columns else {}))
        box = mask_bbox(mask)
        if box is not None:
            rle = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
            x0, y0, x1, y1 = box
            annotations.append({
                "id": len(annotations) + 1, "image_id": n, "category_id": cat[row.label], "iscrowd": 0,
                "segmentation": {"size": [int(s) for s in rle["size"]], "counts": rle["counts"].decode("ascii")},
                "area": float(mask.sum()), "bbox": [x0, y0, x1 - x0, y1 - y0],
                "attributes": _attributes(row, table.columns),
            })
        bar.update(1)
    write_json(out / INSTANCES, {
        "info": {"description": "deformsim synthetic parts", "version": "1.0"}, "licenses": [],
        "categories": CATEGORIES, "images": images, "annotations": annotations,
    })
    masks = "the dense part masks" if table["mask_src"].iloc[0] == "dense" else "the render's alpha"
    return {"images": len(images), "annotations": len(annotations), "linked": linked, "masks": masks,
            "readme": README.format(out=final, masks=masks)}
