"""An export's folder: claimed before any work, filled with links (or copies) of the dataset's files, swapped in whole."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from deformsim.errors import UserError
from deformsim.outputs import check_folder_target

MARKER = "export.json"  # what marks a folder as a deformsim export (the only kind --overwrite replaces)


def claim_export(out: Path, overwrite: bool) -> Path:
    """Check ``out`` before any work: new or empty, or an earlier export to be replaced with ``overwrite``."""
    out = check_folder_target(out, "OUT", replace=True)
    if not out.is_dir() or not any(out.iterdir()):
        return out
    if not (out / MARKER).is_file():
        raise UserError(f"OUT {out} holds files but no deformsim export: choose a new or empty folder (it is never "
                        "replaced)")
    if not overwrite:
        raise UserError(f"OUT {out} holds an export already: pass --overwrite to replace it, or choose another folder")
    return out


def place(src: str | Path, dst: Path) -> bool:
    """Hard-link ``src`` at ``dst`` (same filesystem), else copy it; True when linked. The source is never moved."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(src, dst)
        return True
    except OSError:
        shutil.copyfile(src, dst)
        return False
