"""Named image variants of a generated dataset, as tables that training and evaluation read.

``black`` and ``green`` are the rendered camera-background variants (``rgba`` is the exact-alpha render);
any other name is a composited variant written by ``deformsim composite`` under ``variants/NAME/``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import UserError

VARIANT_MANIFEST = "manifest.parquet"


def list_variants(root: str | Path) -> list[str]:
    layout = Layout(Path(root))
    made = sorted(p.parent.name for p in (layout.root / "variants").glob(f"*/{VARIANT_MANIFEST}"))
    return [k for k in RENDER_KINDS if k != "rgba"] + made


def variant_table(root: str | Path, name: str) -> pd.DataFrame:
    """Columns ``id, path, label, y`` plus the variant's own columns; ``path`` and the dense maps' columns
    (``mask``, ``region``, ...: the variant's own maps where it has them) are absolute paths."""
    layout = Layout(Path(root))
    manifest = read_manifest(layout.root)
    if name in RENDER_KINDS:
        return _absolute(manifest.assign(path=manifest[name]), layout.root)
    vpath = layout.variant_dir(name) / VARIANT_MANIFEST
    if not vpath.is_file():
        raise UserError(f"variant '{name}' not found in {root} (have: {', '.join(list_variants(root))})")
    v = pd.read_parquet(vpath)
    df = manifest.drop(columns=[c for c in v.columns if c != "id" and c in manifest.columns]).merge(v, on="id")
    return _absolute(df.assign(path=df["image"]), layout.root)


def has_own_maps(root: str | Path, name: str) -> bool:
    """Whether composited variant ``name`` carries its own moved dense maps (``deformsim composite`` of a dense
    dataset writes mask, deform and region together); render variants use the render's maps."""
    import pyarrow.parquet as pq

    if name in RENDER_KINDS:
        return False
    return "region" in pq.read_schema(Layout(Path(root)).variant_dir(name) / VARIANT_MANIFEST).names


def _absolute(df: pd.DataFrame, root: Path) -> pd.DataFrame:
    for col in ("path", *(k for k in DENSE_KINDS if k in df.columns)):
        df[col] = [str(root / p) for p in df[col]]
    return df
