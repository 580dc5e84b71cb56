"""Photos given by the user: labelled folders (``intact/`` + ``deformed/``) and lists of images to predict on.

The rule for a labelled folder: every image under ``intact/`` (or ``good/``) is intact and every image under
``deformed/`` (or ``defect/``) deformed, subfolders included; :func:`describe` says what was found where.
"""

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


def describe(table: pd.DataFrame, folder: str | Path) -> str:
    """What a labelled folder holds, per class and subfolder, e.g. ``40 intact (intact/ 38, intact/old/ 2), ...``."""
    root = Path(folder).resolve()
    parts = []
    for label in CLASSES:
        paths = table.loc[table["label"] == label, "path"]
        where = pd.Series([Path(p).parent.relative_to(root).as_posix() + "/" for p in paths]).value_counts(sort=False)
        inside = ", ".join(f"{d} {n}" for d, n in sorted(where.items()))
        parts.append(f"{len(paths)} {label} ({inside})")
    return f"{folder}: " + ", ".join(parts)


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
