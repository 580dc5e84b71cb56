"""ImageFolder layout (torchvision ``ImageFolder``, Hugging Face ``imagefolder``): one folder per class.

    OUT/intact/ID.png, OUT/deformed/ID.png
    OUT/labels.csv        id, file, label, y and the severity columns the dataset has
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from deformsim.atomic import atomic_path
from deformsim.export.files import place
from deformsim.export.source import SEVERITY

README = """deformsim export, ImageFolder layout: one folder per class (intact/, deformed/).

torchvision:   torchvision.datasets.ImageFolder("{out}")   # classes sorted by name: deformed = 0, intact = 1
Hugging Face:  datasets.load_dataset("imagefolder", data_dir="{out}")
labels.csv lists every image with its label (y: 1 = deformed) and its severity where the dataset records it.
Views of one rendered part share the 'sample' number: split by it to keep them on one side of a split.
"""


def write_imagefolder(table: pd.DataFrame, out: Path, final: Path, bar, copy: bool = False) -> dict:
    """Fill ``out`` (to become ``final``; hard links unless ``copy``); the summary for export.json and the README's text."""
    rows, linked = [], 0
    for row in table.itertuples(index=False):
        file = f"{row.label}/{row.id}{Path(row.path).suffix}"
        linked += place(row.path, out / file, copy)
        rows.append({"id": row.id, "file": file, "label": row.label, "y": int(row.y),
                     **{c: getattr(row, c) for c in ("sample", *SEVERITY) if c in table.columns}})
        bar.update(1)
    with atomic_path(out / "labels.csv") as tmp:
        pd.DataFrame(rows).to_csv(tmp, index=False)
    counts = pd.Series([r["label"] for r in rows]).value_counts()
    return {"images": len(rows), "linked": linked, "classes": {k: int(v) for k, v in sorted(counts.items())},
            "readme": README.format(out=final)}
