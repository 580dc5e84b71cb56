"""Image tables, the train/validation split and image loading for training and prediction."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import torch
from PIL import Image, UnidentifiedImageError

from deformsim.errors import UserError

IMAGE_EXTS = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}
CLASSES = ("intact", "deformed")  # index = y
# Folder names of each class: ours first, then anomalib's.
FOLDERS = {"intact": ("intact", "good"), "deformed": ("deformed", "defect")}


def _images_in(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in IMAGE_EXTS)


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
        images = _images_in(sub)
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
            found = _images_in(item)
            if not found:
                raise UserError(f"{item} holds no images")
            out += found
        elif item.is_file():
            out.append(item)
        else:
            raise UserError(f"image not found: {item}")
    return out


def check_table(table: pd.DataFrame) -> None:
    missing = {"id", "path", "y"} - set(table.columns)
    if missing:
        raise UserError(f"image table lacks column(s) {', '.join(sorted(missing))}")
    if table.empty:
        raise UserError("image table is empty: nothing to train on")
    bad = set(table["y"].unique()) - {0, 1}
    if bad:
        raise UserError(f"labels y must be 0 (intact) or 1 (deformed), got {sorted(bad)}")
    gone = [p for p in table["path"] if not Path(p).is_file()]
    if gone:
        raise UserError(f"{len(gone)} image(s) missing, e.g. {gone[0]}")


def split(table: pd.DataFrame, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Row positions of the training and validation parts, stratified by ``y``.

    Rows of one ``sample`` (the cameras of one rendered object) stay together so views of one object never
    straddle the split; tables without that column split by row.
    """
    rng = np.random.default_rng(seed)
    groups = table["sample"].to_numpy() if "sample" in table.columns else np.arange(len(table))
    y = table["y"].to_numpy()
    train = []
    for cls in (0, 1):
        g = rng.permutation(np.unique(groups[y == cls]))
        # at least one group of a class in each part whenever the class has two or more
        n = len(g) if len(g) < 2 else min(len(g) - 1, max(1, round(fraction * len(g))))
        train.append(g[:n])
    is_train = np.isin(groups, np.concatenate(train))
    return np.flatnonzero(is_train), np.flatnonzero(~is_train)


def load_image(path: str | Path, size: int) -> torch.Tensor:
    """0-1 RGB float tensor (3, size, size); the image is resized (not cropped) to a square, as in the paper."""
    try:
        with Image.open(path) as im:
            im = im.convert("RGB").resize((size, size), Image.BILINEAR)
    except (UnidentifiedImageError, OSError) as exc:
        raise UserError(f"cannot read image {path}: {exc}") from None
    return torch.from_numpy(np.asarray(im).copy()).permute(2, 0, 1).float().div_(255)


def augmenter(size: int):
    """Random resized crop, horizontal flip and small colour jitter (uses torch's seeded global RNG)."""
    from torchvision.transforms import v2

    return v2.Compose([
        v2.RandomResizedCrop(size, scale=(0.8, 1.0), ratio=(0.9, 1.1), antialias=True),
        v2.RandomHorizontalFlip(),
        v2.ColorJitter(brightness=0.15, contrast=0.15, saturation=0.15, hue=0.02),
    ])


class ImageSet(torch.utils.data.Dataset):
    def __init__(self, paths: list, size: int, transform=None):
        self.paths, self.size, self.transform = [str(p) for p in paths], size, transform

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i: int) -> torch.Tensor:
        x = load_image(self.paths[i], self.size)
        return self.transform(x) if self.transform else x
