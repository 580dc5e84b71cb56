"""Image tables (``id, path, y`` and more) for training: where they come from, their checks, their split."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from deformsim.dataset.layout import Layout
from deformsim.dataset.real import real_table
from deformsim.dataset.variants import variant_table
from deformsim.errors import UserError
from deformsim.log import get_logger

log = get_logger(__name__)


def load_table(data: Path, variant: str | None, default_variant: str, min_region: float = 0.0) -> pd.DataFrame:
    """A generated dataset's variant table (less its unseen damage, :func:`drop_unseen`), or a folder of photos in
    intact/ and deformed/ subfolders, checked by :func:`check_table`."""
    if Layout(data).manifest.is_file():
        name = variant or default_variant
        source = f"variant '{name}' of {data}"
        table = drop_unseen(variant_table(data, name), min_region, source)
    elif variant:
        raise UserError(f"--variant {variant} needs a generated dataset, but {data} has no manifest.parquet")
    else:
        table, source = real_table(data), str(data)
    check_table(table, source)
    return table


def check_table(table: pd.DataFrame, source: str = "the image table") -> None:
    """A :class:`UserError` naming ``source`` unless the table has rows, columns ``id, path, y``, 0/1 labels of
    both classes and every image."""
    missing = {"id", "path", "y"} - set(table.columns)
    if missing:
        raise UserError(f"{source} lacks column(s) {', '.join(sorted(missing))}")
    if table.empty:
        raise UserError(f"{source} is empty: nothing to train on")
    bad = set(table["y"].unique()) - {0, 1}
    if bad:
        raise UserError(f"{source}: labels y must be 0 (intact) or 1 (deformed), got {', '.join(sorted(map(str, bad))[:5])}")
    deformed = int((table["y"] == 1).sum())
    if deformed in (0, len(table)):
        raise UserError(f"{source} has {len(table) - deformed} intact and {deformed} deformed images: training needs "
                        "both classes (generate more images, e.g. a larger --n)")
    gone = [p for p in table["path"] if not Path(p).is_file()]
    if gone:
        raise UserError(f"{source}: {len(gone)} image(s) missing, e.g. {gone[0]}")


def drop_unseen(table: pd.DataFrame, min_region: float, source: str = "the image table") -> pd.DataFrame:
    """``table`` without its deformed images whose ``region_fraction`` (the share of the visible part that is
    deformed) is below ``min_region`` (``train.min_region``); ``table`` itself when ``min_region`` is 0."""
    if not min_region:
        return table
    if "region_fraction" not in table.columns:
        raise UserError(f"train.min_region {min_region:g} needs the deformed region of every image: {source} was "
                        "rendered without render.dense (set render.dense: true and generate again)")
    keep = (table["y"] == 0) | (table["region_fraction"] >= min_region)
    log.info("train.min_region %g: %d of %d deformed images of %s left out (damage too small or out of view)",
             min_region, int((~keep).sum()), int((table["y"] == 1).sum()), source)
    return table[keep].reset_index(drop=True)


def split(table: pd.DataFrame, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Row positions of the training and validation parts, stratified by ``y``.

    Rows of one ``sample`` (the cameras of one rendered object) stay together so views of one object never
    straddle the split, and in a dataset drawn with ``generate.paired`` so do twins (column ``pair``: one scene,
    one dented and one intact object), their groups a stratum of their own; tables without either split by row.
    """
    rng = np.random.default_rng(seed)
    key = next((c for c in ("pair", "sample") if c in table.columns), None)
    groups = table[key].to_numpy() if key else np.arange(len(table))
    y = table["y"].to_numpy()
    both = np.intersect1d(groups[y == 0], groups[y == 1])  # twins: groups that hold both classes
    strata = [np.setdiff1d(groups[y == cls], both) for cls in (0, 1)] + ([both] if len(both) else [])
    train = []
    for g in strata:
        g = rng.permutation(g)
        # at least one group of a class in each part whenever the class has two or more
        n = len(g) if len(g) < 2 else min(len(g) - 1, max(1, round(fraction * len(g))))
        train.append(g[:n])
    is_train = np.isin(groups, np.concatenate(train))
    return np.flatnonzero(is_train), np.flatnonzero(~is_train)
