"""The manifest: one row per image with every sampled parameter, file paths and timing.

Rows are built from a sample's parameters (pure), kept per sample in ``samples/NNNNNN.json`` while a run
goes, and consolidated into ``manifest.parquet`` (and a CSV for people) sorted by image id, so the result
does not depend on the order or the worker in which samples finished.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from deformsim.atomic import atomic_path, write_json
from deformsim.dataset.layout import RENDER_KINDS, Layout, image_id
from deformsim.dataset.paths import file_stem
from deformsim.dataset.rendered import Rendered
from deformsim.errors import UserError
from deformsim.sampling import SampleParams
from deformsim.sampling.features import feature_columns
from deformsim.schema import shown

# Columns that measure the run rather than describe the data: excluded when comparing manifests.
VOLATILE_COLUMNS = ("render_seconds",)
LABELS = ("intact", "deformed")  # by y
# columns that deformsim reads as numbers (grouping, labels, severities, the masks' boxes)
NUMERIC = ("sample", "camera", "y", "seed", "pair", "extent", "max_disp_mm", "visible_disp_mm", "region_fraction",
           "bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1")


def rows_for(p: SampleParams, layout: Layout, rendered: Rendered, camera_scale: float = 1.0) -> list[dict]:
    """The manifest rows of one sample, one per camera: its drawn parameters, the worker's columns for the whole
    sample after its drawn pose (with ``pose.mode`` drop: ``rest_qw..rest_qz``, ``rest_tilt``, ...), the render
    features' drawn columns (by the registry, :mod:`deformsim.sampling.features`), the image paths and timing, then
    each image's columns from the worker's render features (their image paths first)."""
    rows = []
    framing = framing_columns(p)
    for c, cam in enumerate(p.cameras):
        iid = image_id(p.index, c)
        row = {
            "id": iid,
            "sample": p.index,
            "camera": c,
            "label": p.label,
            "y": int(p.deformed),
            "seed": p.seed,
            **({"pair": p.pair} if p.pair is not None else {}),
            "families": ",".join(p.families),
            "extent": p.extent,
            "bank": p.bank,
            "bank_amount": p.bank_amount,
            **{f"key_{k}": v for k, v in p.keys.items()},
            **{f"disp_{k}": v for k, v in p.displacement.items()},
            "seal": p.seal,
            "tab": p.tab,
            "pose_tilt": p.pose_tilt,
            "pose_axis": p.pose_axis,
            **rendered.sample_columns,
            **feature_columns(p),
            "hdri": p.hdri,
            "hdri_rotation": p.hdri_rotation,
            "hdri_strength": p.hdri_strength,
            "cam_azimuth": cam.azimuth,
            "cam_polar": cam.polar,
            "cam_radius": cam.radius,
            **{col: getattr(cam, field) for field, col in framing},
            "camera_scale": camera_scale,
            "design": json.dumps(p.design.__dict__ if p.design else None, sort_keys=True),
            "material": json.dumps(p.material.to_dict() if p.material else None, sort_keys=True),
            **shape_columns(p),
            **appearance_columns(p),
            **{kind: layout.rel(layout.image(kind, iid)) for kind in RENDER_KINDS},
            "render_seconds": rendered.render_seconds[c],
            **(rendered.image_columns[c] if rendered.image_columns else {}),
        }
        rows.append(row)
    return rows


def shape_columns(p: SampleParams) -> dict:
    """The drawn shape (``object.shapes``), when the sample has one: the can size and its nominal dimensions (mm),
    proportions, per-axis scale, taper and bulge."""
    s = p.shape
    if s is None:
        return {}
    return {"shape_size": s.size, "shape_diameter_mm": s.diameter, "shape_height_mm": s.height, "shape_rim": s.rim,
            "shape_neck": s.neck, "shape_dome": s.dome, **{f"shape_scale_{a}": v for a, v in zip("xyz", s.scale)},
            "shape_taper": s.taper, "shape_bulge": s.bulge}


def appearance_columns(p: SampleParams) -> dict:
    """The drawn artwork and finish (``render.appearance``), when the sample has them."""
    a = p.appearance
    if a is None:
        return {}
    return {"appearance_style": a.style, "appearance_seed": a.seed, "appearance_metallic": a.metallic,
            "appearance_photo": a.photo, "appearance_gloss": a.gloss, "appearance_roughness": a.roughness}


def framing_columns(p: SampleParams) -> list[tuple[str, str]]:
    """(CameraParams field, manifest column) of each per-image framing option the sample's config turns on
    (``camera.fill``, ``offset``, ``partial``, a ``lens_mm`` range, ``fstop``), so a manifest without them is as
    it was. Told by the drawn values: an option that is on never draws its off value (0, or "" for the cut side;
    both shifts of every image exactly 0 with offset on has probability 2**-53 per draw)."""
    cams = p.cameras
    on = {
        "fill": any(c.fill > 0 for c in cams),
        "shift_x": any(c.shift_x != 0 or c.shift_y != 0 for c in cams),
        "cut": any(c.cut_side != "" for c in cams),
        "lens": any(c.lens > 0 for c in cams),
        "fstop": any(c.fstop > 0 for c in cams),
    }
    groups = {"shift_x": ("shift_x", "shift_y"), "cut": ("cut", "cut_side")}
    return [(f, f"cam_{f}") for key, flag in on.items() if flag for f in groups.get(key, (key,))]


def write_record(layout: Layout, p: SampleParams, rows: list[dict]) -> None:
    write_json(layout.sample_record(p.index), {"params": p.to_dict(), "rows": rows})


def read_record(layout: Layout, index: int) -> dict | None:
    """A finished sample's record, or None when it is missing, unreadable or its images are gone."""
    path = layout.sample_record(index)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    for row in rec.get("rows", []):
        if not all((layout.root / path).is_file() for path in image_paths(layout, row)):
            return None
    return rec


def image_paths(layout: Layout, row: dict) -> list[str]:
    """The images a manifest row names: each column named after an image kind whose value is that image's path."""
    return [v for k, v in row.items() if isinstance(v, str) and v == layout.rel(layout.image(k, row["id"]))]


def consolidate(layout: Layout, indices: list[int]) -> pd.DataFrame:
    """Merge the records of ``indices`` into manifest.parquet and manifest.csv (atomically)."""
    rows = []
    for i in indices:
        rec = read_record(layout, i)
        if rec is None:
            raise RuntimeError(f"sample {i} has no complete record")
        rows.extend(rec["rows"])
    df = pd.DataFrame(rows).sort_values("id").reset_index(drop=True)
    with atomic_path(layout.manifest) as tmp:
        df.to_parquet(tmp, index=False)
    with atomic_path(layout.manifest_csv) as tmp:
        df.to_csv(tmp, index=False)
    return df


def read_manifest(root: str | Path) -> pd.DataFrame:
    """Load a dataset's manifest; a clear error when the folder is not a generated dataset."""
    layout = Layout(Path(root))
    if not layout.manifest.is_file():
        raise UserError(f"{root} is not a generated dataset: {layout.manifest.name} is missing (run deformsim generate)")
    fix = "rerun deformsim generate on the dataset to write it again"
    df = read_parquet(layout.manifest, "manifest", fix)
    if "y" in df.columns and not df["y"].isin([0, 1]).all():
        raise UserError(f"manifest {layout.manifest} has labels y other than 0 (intact) and 1 (deformed): {fix}")
    check_columns(df, f"manifest {layout.manifest}", fix)
    return df


def check_columns(df: pd.DataFrame, what: str, fix: str) -> None:
    """A :class:`UserError` naming ``what`` (and the row) unless every column holds single values (text or numbers,
    no lists), the columns read as numbers (:data:`NUMERIC`) numbers, every ``id`` a plain file name
    (:func:`~deformsim.dataset.paths.file_stem`: it names the image's files) seen once, and every ``label`` intact
    or deformed, as its ``y`` says."""
    for col in df.columns:
        if df[col].dtype == object and not all(v is None or isinstance(v, str) for v in df[col]):
            raise UserError(f"{what} column {shown(col, 60)} holds values that are neither text nor numbers: {fix}")
        if col in NUMERIC and not (pd.api.types.is_numeric_dtype(df[col]) and not pd.api.types.is_bool_dtype(df[col])):
            raise UserError(f"{what} column {col} holds {df[col].dtype} values where numbers belong: {fix}")
    if "id" in df.columns:
        for i, iid in enumerate(df["id"]):
            file_stem(iid, f"{what} row {i} (id)")
        repeated = df["id"][df["id"].duplicated()]
        if len(repeated):
            raise UserError(f"{what} has the id {shown(repeated.iloc[0], 80)!r} more than once: {fix}")
    if "label" in df.columns:
        ys = df["y"] if "y" in df.columns else [None] * len(df)
        for i, (label, y) in enumerate(zip(df["label"], ys)):
            if not (isinstance(label, str) and label in LABELS):
                shown_label = repr(shown(label, 80)) if isinstance(label, str) else shown(label, 80)
                raise UserError(f"{what} row {i} (label): {shown_label} is not a class: intact or deformed")
            if y is not None and LABELS.index(label) != y:
                raise UserError(f"{what} row {i}: label {label!r} but y {y}: {fix}")


def read_parquet(path: Path, what: str, fix: str = "") -> pd.DataFrame:
    """The table in ``path``, read on this thread (pyarrow's thread pool can abort the interpreter at exit);
    a corrupt or foreign file is a :class:`UserError` naming it as ``what``, followed by ``fix``."""
    import pyarrow.parquet as pq

    try:
        return pq.read_table(path, use_threads=False).to_pandas(use_threads=False)
    except Exception as exc:  # pyarrow raises several types for corrupt files
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "corrupt, cut short or not parquet"
        raise UserError(f"{what} {path} is unreadable ({reason})" + (f": {fix}" if fix else "")) from None


def stable_view(df: pd.DataFrame) -> pd.DataFrame:
    """The manifest without run-time measurements: equal for equal seeds and settings."""
    return df.drop(columns=[c for c in VOLATILE_COLUMNS if c in df.columns])
