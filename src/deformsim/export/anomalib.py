"""anomalib ``Folder`` layout: normal pictures to learn from, held-out normal and abnormal ones, ground-truth masks.

    OUT/train/good/ID.png                 intact parts (normal_dir)
    OUT/test/good/ID.png                  intact parts of held-out scenes (normal_test_dir)
    OUT/test/deformed/ID.png              deformed parts (abnormal_dir)
    OUT/ground_truth/deformed/ID.png      their deformed-region masks, 0/255, same file names (mask_dir; dense only)
    OUT/folder.yaml                       the ``anomalib.data.Folder`` arguments

The held-out intact scenes are a seeded fraction of the intact samples, every camera of a sample on one side.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import yaml

from deformsim.atomic import write_text
from deformsim.dataset.tables import split
from deformsim.export.files import place

TEST_FRACTION = 0.2  # of the intact scenes, held out as normal test images

README = """deformsim export, anomalib Folder layout (normal_dir, normal_test_dir, abnormal_dir{mask_line}).

Python:
    from anomalib.data import Folder
    datamodule = Folder({kwargs})
Command line: folder.yaml holds the same arguments as a data config (anomalib train --model Patchcore --data folder.yaml).
{masks}
train/good holds the intact parts of {train} scene(s); test/good those of {test} other scene(s) (a seeded {frac:.0%} of
the intact scenes, all cameras of a scene on one side); test/deformed every deformed part.
"""


def folder_args(final: Path, masks: bool) -> dict:
    """The ``anomalib.data.Folder`` arguments for the export at ``final``."""
    args = {"name": "deformsim", "root": str(final.resolve()), "normal_dir": "train/good",
            "normal_test_dir": "test/good", "abnormal_dir": "test/deformed"}
    return args | ({"mask_dir": "ground_truth/deformed"} if masks else {})


def _scenes(rows: pd.DataFrame) -> int:
    return int(rows["sample"].nunique()) if "sample" in rows.columns else len(rows)


def write_anomalib(table: pd.DataFrame, out: Path, final: Path, bar, copy: bool = False, seed: int = 0) -> dict:
    """Fill ``out`` (to become ``final``; hard links unless ``copy``); the summary for export.json and the README's text."""
    masks = bool((table["mask_src"] == "dense").all())
    intact = table[table["y"] == 0].reset_index(drop=True)
    train_rows, _ = split(intact, 1 - TEST_FRACTION, seed) if len(intact) else ([], [])
    held_out = set(intact["id"]) - set(intact["id"].iloc[train_rows])
    linked, empty_masks = 0, 0
    for row in table.itertuples(index=False):
        name = f"{row.id}{Path(row.path).suffix}"
        if row.y == 1:
            linked += place(row.path, out / "test" / "deformed" / name, copy)
            if masks:
                place(row.region_path, out / "ground_truth" / "deformed" / name, copy)
                empty_masks += int(getattr(row, "region_fraction", 1.0) == 0)
        else:
            linked += place(row.path, out / ("test" if row.id in held_out else "train") / "good" / name, copy)
        bar.update(1)
    args = folder_args(final, masks)
    write_text(out / "folder.yaml", yaml.safe_dump({"class_path": "anomalib.data.Folder", "init_args": args},
                                                    sort_keys=False))
    note = (f"Masks: the deformed-region masks (render.region_threshold_mm); {empty_masks} deformed image(s) show no "
            "region above the threshold and have an all-black mask." if masks else
            "No masks: the dataset has no dense maps that fit these pictures (render with render.dense: true), so "
            "this export is for image-level anomaly detection (classification) only.")
    counts = {"train/good": len(intact) - len(held_out), "test/good": len(held_out),
              "test/deformed": int((table["y"] == 1).sum())}
    readme = README.format(mask_line=", mask_dir" if masks else "", masks=note, frac=TEST_FRACTION,
                           kwargs=", ".join(f"{k}={v!r}" for k, v in args.items()),
                           train=_scenes(intact[~intact["id"].isin(held_out)]), test=_scenes(intact[intact["id"].isin(held_out)]))
    return {"images": len(table), "linked": linked, "folders": counts, "masks": masks, "readme": readme}
