"""Named image variants of a generated dataset, as tables that training and evaluation read.

``black`` and ``green`` are the rendered camera-background variants (``rgba`` is the exact-alpha render);
any other name is a composited variant written by ``deformsim composite`` under ``variants/NAME/``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from deformsim.dataset.layout import RENDER_KINDS, Layout
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import UserError

VARIANT_MANIFEST = "manifest.parquet"


def list_variants(root: str | Path) -> list[str]:
    layout = Layout(Path(root))
    made = sorted(p.parent.name for p in (layout.root / "variants").glob(f"*/{VARIANT_MANIFEST}"))
    return [k for k in RENDER_KINDS if k != "rgba"] + made


def variant_table(root: str | Path, name: str) -> pd.DataFrame:
    """Columns ``id, path, label, y`` (``path`` absolute) plus the variant's own columns."""
    layout = Layout(Path(root))
    manifest = read_manifest(layout.root)
    if name in RENDER_KINDS:
        df = manifest.copy()
        df["path"] = [str(layout.root / p) for p in df[name]]
        return df
    vpath = layout.variant_dir(name) / VARIANT_MANIFEST
    if not vpath.is_file():
        raise UserError(f"variant '{name}' not found in {root} (have: {', '.join(list_variants(root))})")
    v = pd.read_parquet(vpath)
    df = manifest.drop(columns=[c for c in v.columns if c != "id" and c in manifest.columns]).merge(v, on="id")
    df["path"] = [str(layout.root / p) for p in df["image"]]
    return df
