"""Named image variants of a generated dataset, as tables that training and evaluation read.

``black`` and ``green`` are the rendered camera-background variants (``rgba`` is the exact-alpha render);
any other name is a composited variant written by ``deformsim composite`` under ``variants/NAME/``. A composited
variant is read only when it holds exactly the dataset's images: one composited before the dataset was extended
is refused, to be composited again.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout
from deformsim.dataset.manifest import check_columns, read_manifest, read_parquet
from deformsim.dataset.paths import dataset_files
from deformsim.errors import UserError

VARIANT_MANIFEST = "manifest.parquet"
_REMAKE = "rerun deformsim composite to make it again"


def made_manifests(root: str | Path) -> list[Path]:
    """The manifests of the composited variants under ``root``, sorted; not those of a run's staging folder
    (``.NAME.staging-...``, :func:`deformsim.outputs.replacing`)."""
    found = (Path(root) / "variants").glob(f"*/{VARIANT_MANIFEST}")
    return sorted(p for p in found if not p.parent.name.startswith("."))


def list_variants(root: str | Path) -> list[str]:
    made = [p.parent.name for p in made_manifests(root)]
    return [k for k in RENDER_KINDS if k != "rgba"] + made


def variant_table(root: str | Path, name: str) -> pd.DataFrame:
    """Columns ``id, path, label, y`` plus the variant's own columns; ``path`` and the dense maps' columns
    (``mask``, ``region``, ...: the variant's own maps where it has them) are absolute paths."""
    layout = Layout(Path(root))
    manifest = read_manifest(layout.root)
    if name in RENDER_KINDS:
        if name not in manifest.columns:
            raise UserError(f"dataset {layout.root} has no {name} images (its manifest lacks the column)")
        return _absolute(manifest.assign(path=manifest[name]), layout.root)
    v = _checked_variant(layout, manifest, name)
    df = manifest.drop(columns=[c for c in v.columns if c != "id" and c in manifest.columns]).merge(v, on="id")
    return _absolute(df.assign(path=df["image"]), layout.root)


def is_current(root: str | Path, name: str) -> bool:
    """Whether composited variant ``name`` exists, is readable and holds exactly the dataset's images."""
    layout = Layout(Path(root))
    try:
        _checked_variant(layout, read_manifest(layout.root), name)
    except UserError:
        return False
    return True


def stale_variants(root: str | Path) -> list[str]:
    """The composited variants of the dataset in ``root`` that no longer hold exactly its images (it grew since)."""
    return [name for name in list_variants(root) if name not in RENDER_KINDS and not is_current(root, name)]


def has_own_maps(root: str | Path, name: str) -> bool:
    """Whether composited variant ``name`` carries its own moved dense maps (``deformsim composite`` of a dense
    dataset writes mask, deform and region together); render variants use the render's maps."""
    if name in RENDER_KINDS:
        return False
    path = Layout(Path(root)).variant_dir(name) / VARIANT_MANIFEST
    return "region" in read_parquet(path, "variant manifest", _REMAKE).columns


def _checked_variant(layout: Layout, manifest: pd.DataFrame, name: str) -> pd.DataFrame:
    """Variant ``name``'s own manifest: readable, with ``id`` and ``image``, one row per image of the dataset."""
    vpath = layout.variant_dir(name) / VARIANT_MANIFEST
    if not vpath.is_file():
        raise UserError(f"variant '{name}' not found in {layout.root} (have: {', '.join(list_variants(layout.root))})")
    v = read_parquet(vpath, "variant manifest", _REMAKE)
    missing = {"id", "image"} - set(v.columns)
    if missing:
        raise UserError(f"variant manifest {vpath} lacks column(s) {', '.join(sorted(missing))}: {_REMAKE}")
    check_columns(v, f"variant manifest {vpath}", _REMAKE)
    if not all(isinstance(p, str) for p in v["image"]):
        raise UserError(f"variant manifest {vpath} has image paths that are not text: {_REMAKE}")
    ids, own = set(manifest["id"].astype(str)), set(v["id"].astype(str))
    if len(v) != len(manifest) or own != ids:
        raise UserError(f"variant '{name}' does not match the images of {layout.root}: it holds {len(v)} images, "
                        f"the dataset {len(manifest)} ({len(ids - own)} of them not in the variant); rerun "
                        f"deformsim composite {layout.root} --name {name} with the settings in its composite.json")
    return v


def _absolute(df: pd.DataFrame, root: Path) -> pd.DataFrame:
    """Every image and map path of ``df`` made absolute, each checked to lie inside the dataset."""
    for col in ("path", *(k for k in DENSE_KINDS if k in df.columns)):
        df[col] = dataset_files(root, df[col], (f"row {i} ({col})" for i in df["id"]))
    return df
