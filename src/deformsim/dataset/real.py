"""Photos given by the user: labelled folders (``intact/`` + ``deformed/``) and lists of images to predict on."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from deformsim.dataset.images import CLASSES, IMAGE_EXTS, images_in
from deformsim.errors import UserError

# Folder names of each class: ours first, then anomalib's.
FOLDERS = {"intact": ("intact", "good"), "deformed": ("deformed", "defect")}


def real_table(folder: str | Path) -> pd.DataFrame:
    """Photos sorted into ``intact/`` and ``deformed/`` (or ``good/`` and ``defect/``) as ``id, path, label, y``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"image folder not found: {folder}")
    rows = []
    for y, label in enumerate(CLASSES):
        sub = next((folder / n for n in FOLDERS[label] if (folder / n).is_dir()), None)
        if sub is None:
            names = " or ".join(f"{n}/" for n in FOLDERS[label])
            raise UserError(f"{folder} has no {names} subfolder (expected intact/ + deformed/ or good/ + defect/)")
        images = images_in(sub)
        if not images:
            raise UserError(f"{sub} holds no images ({', '.join(sorted(IMAGE_EXTS))})")
        rows += [{"id": f"{label}/{p.relative_to(sub).with_suffix('')}", "path": str(p.resolve()), "label": label, "y": y}
                 for p in images]
    return pd.DataFrame(rows)


def expand_images(items: list[str | Path]) -> list[Path]:
    """Image files named directly or found (recursively, sorted) in folders; a clear error for anything else."""
    out = []
    for item in map(Path, items):
        if item.is_dir():
            found = images_in(item)
            if not found:
                raise UserError(f"{item} holds no images")
            out += found
        elif item.is_file():
            out.append(item)
        else:
            raise UserError(f"image not found: {item}")
    return out
