"""A tiny generated dataset in the dense ground-truth format, drawn without Blender.

Each sample is a grey disc (the part) on a dark background, seen by two "cameras" (the second mirrored). A deformed
sample carries one or both families: ``dent``, a dark spot whose radius grows with the displacement, and ``crease``,
a bright bar. The region is the visible spot and bar, the deformation map holds the displacement there (a little
elsewhere on the part); ``max_disp_mm`` is the sample's displacement, ``family_<name>`` its families.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw

from deformsim.dataset.dense import DEFORM_SCALE, encode_u16, map_stats, mask_image, save_png
from deformsim.dataset.layout import Layout, image_id

FAMILIES = ("dent", "crease")
THRESHOLD_MM = 1.0


def _draw(rng: np.random.Generator, size: int, families: list[str], disp: float):
    """Image, part mask and deformation map (mm) of one view."""
    yy, xx = np.mgrid[:size, :size]
    c = size / 2 + rng.uniform(-size / 12, size / 12, 2)
    part = (xx - c[0]) ** 2 + (yy - c[1]) ** 2 <= (0.36 * size) ** 2
    deform = np.where(part, rng.uniform(0, 0.4, (size, size)), 0.0)
    img = np.clip(rng.normal(20, 8, (size, size, 3)), 0, 255)
    img[part] = rng.integers(120, 170, 3)
    if "dent" in families:
        r = size * (0.07 + 0.012 * disp)
        d = c + rng.uniform(-0.12 * size, 0.12 * size, 2)
        spot = part & ((xx - d[0]) ** 2 + (yy - d[1]) ** 2 <= r * r)
        img[spot] = (40, 40, 45)
        deform[spot] = disp
    if "crease" in families:
        bar = Image.new("L", (size, size))
        y0 = c[1] + rng.uniform(-0.15, 0.15) * size
        ImageDraw.Draw(bar).line([(c[0] - 0.3 * size, y0), (c[0] + 0.3 * size, y0 + rng.uniform(-4, 4))], fill=255,
                                 width=max(2, size // 16))
        bar = part & (np.asarray(bar) > 0)
        img[bar] = (235, 235, 220)
        deform[bar] = np.maximum(deform[bar], 0.6 * disp)
    return img.astype(np.uint8), part, deform


def make_dense_dataset(root: Path, n_per_class: int, size: int = 64, seed: int = 0) -> Path:
    """Write ``n_per_class`` intact and deformed samples (2 views each) under ``root``; returns ``root``."""
    rng = np.random.default_rng(seed)
    layout = Layout(root)
    rows = []
    for s in range(2 * n_per_class):
        deformed = s % 2 == 1
        fams = [f for f in FAMILIES if rng.random() < 0.6] or [FAMILIES[int(rng.integers(2))]] if deformed else []
        disp = float(rng.uniform(2, 12)) if deformed else 0.0
        for cam in range(2):
            iid = image_id(s, cam)
            img, part, deform = _draw(rng, size, fams, disp)
            if cam:
                img, part, deform = img[:, ::-1], part[:, ::-1], deform[:, ::-1]
            region = part & (encode_u16(deform, DEFORM_SCALE) >= THRESHOLD_MM * DEFORM_SCALE)
            paths = {k: layout.image(k, iid) for k in ("black", "mask", "deform", "region")}
            for p in paths.values():
                p.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.ascontiguousarray(img)).save(paths["black"])
            save_png(paths["mask"], mask_image(part))
            save_png(paths["deform"], encode_u16(deform, DEFORM_SCALE))
            save_png(paths["region"], mask_image(region))
            rows.append({
                "id": iid, "sample": s, "camera": cam, "label": "deformed" if deformed else "intact", "y": int(deformed),
                "families": ",".join(fams), **{k: layout.rel(p) for k, p in paths.items()},
                "max_disp_mm": disp, **map_stats(part, deform, region),
                **{f"family_{f}": int(f in fams) for f in FAMILIES},
            })
    pd.DataFrame(rows).to_parquet(layout.manifest, index=False)
    return root
