"""Image tables (``id, path, y`` and more) for training: where they come from, their checks, their split."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from deformsim.dataset.layout import Layout
from deformsim.dataset.real import real_table
from deformsim.dataset.variants import variant_table
from deformsim.errors import UserError


def load_table(data: Path, variant: str | None, default_variant: str) -> pd.DataFrame:
    """A generated dataset's variant table, or a folder of photos in intact/ and deformed/ subfolders."""
    if Layout(data).manifest.is_file():
        return variant_table(data, variant or default_variant)
    if variant:
        raise UserError(f"--variant {variant} needs a generated dataset, but {data} has no manifest.parquet")
    return real_table(data)


def check_table(table: pd.DataFrame) -> None:
    """A :class:`UserError` unless the table has rows, columns ``id, path, y``, 0/1 labels and every image."""
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
