"""A small dataset in the dense ground-truth format, written without Blender (for fast tests).

Each image shows a flat-coloured part that is not left-right symmetric (a body with a tab on its right); deformed
samples have a dent on the part's right side. Sample 2's camera 1 sees no part at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from deformsim.dataset.dense import (
    DEFORM_SCALE,
    encode_normal,
    encode_u16,
    map_stats,
    mask_image,
    region_mask,
    save_png,
)
from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout, image_id

PART_RGB = (200, 40, 30)
FAMILIES = ("crush", "pinch")
THRESHOLD_MM = 1.0


def part_maps(size: int, shift: int, deformed: bool, visible: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The part's coverage (bool) and its deformation in mm."""
    yy, xx = np.mgrid[0:size, 0:size]
    cx = size // 2 + shift
    mask = (xx >= cx - 10) & (xx < cx + 6) & (yy >= 10) & (yy < size - 8)
    mask |= (xx >= cx + 6) & (xx < cx + 12) & (yy >= 10) & (yy < 18)  # the tab, on the right only
    mask &= visible
    dent = np.clip(3.0 - np.hypot(xx - (cx + 3), yy - (size // 2)) / 2.0, 0, None) if deformed else np.zeros((size, size))
    return mask, np.where(mask, dent, 0.0)


def make_dense_dataset(root: Path, n_samples: int = 4, cameras: int = 2, size: int = 48, dense: bool = True) -> Path:
    """Write ``root`` as a generated dataset (images, manifest.parquet); odd samples are deformed."""
    layout = Layout(root)
    rows = []
    for s in range(n_samples):
        deformed = bool(s % 2)
        for c in range(cameras):
            iid = image_id(s, c)
            mask, deform = part_maps(size, 4 * c - 2, deformed, visible=(s, c) != (2, 1))
            alpha = mask_image(mask)
            rgb = np.zeros((size, size, 3), np.uint8)
            rgb[mask] = PART_RGB
            green = np.where(mask[..., None], rgb, np.array([0, 255, 0], np.uint8))
            for kind, img in (("rgba", np.dstack([rgb, alpha])), ("black", rgb), ("green", green)):
                layout.image(kind, iid).parent.mkdir(parents=True, exist_ok=True)
                Image.fromarray(img).save(layout.image(kind, iid))
            row = {"id": iid, "sample": s, "camera": c, "label": "deformed" if deformed else "intact", "y": int(deformed),
                   "seed": 100 + s, "families": "crush" if deformed else "", "extent": 0.5 * deformed,
                   **{k: layout.rel(layout.image(k, iid)) for k in RENDER_KINDS}}
            if dense:
                region = region_mask(deform, mask, THRESHOLD_MM)
                normal = np.zeros((size, size, 3)) + np.array([0.0, 0.0, 1.0])
                maps = {"mask": alpha, "depth": encode_u16(np.where(mask, 500.0, 0.0), 1.0),
                        "normal": encode_normal(normal, mask), "deform": encode_u16(deform, DEFORM_SCALE),
                        "region": mask_image(region)}
                for kind in DENSE_KINDS:
                    save_png(layout.image(kind, iid), maps[kind])
                    row[kind] = layout.rel(layout.image(kind, iid))
                row.update(map_stats(mask, maps["deform"] / DEFORM_SCALE, region))
                row["max_disp_mm"] = 3.0 if deformed else 0.0
                row.update({f"family_{f}": int(deformed and f == "crush") for f in FAMILIES})
            rows.append(row)
    pd.DataFrame(rows).to_parquet(layout.manifest, index=False)
    return root
