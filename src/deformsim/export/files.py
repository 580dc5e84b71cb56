"""An export's folder: claimed before any work, filled with links (or copies) of the dataset's files, swapped in whole."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from deformsim.errors import UserError
from deformsim.outputs import check_folder_target, check_kind, check_no_nested


def claim_export(out: Path, overwrite: bool) -> Path:
    """Check ``out`` before any work: new or empty, or an earlier export (and nothing else) to be replaced with
    ``overwrite``."""
    out = check_folder_target(out, "OUT", replace=True)
    if check_kind(out, "export", "OUT"):
        if not overwrite:
            raise UserError(f"OUT {out} holds an export already: pass --overwrite to replace it, or choose another "
                            "folder")
        check_no_nested(out, "OUT")
    return out


def place(src: str | Path, dst: Path, copy: bool = False) -> bool:
    """Hard-link ``src`` at ``dst`` (unless ``copy``; when both are on one filesystem), else copy it; True when
    linked. The source is never moved."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    if not copy:
        try:
            os.link(src, dst)
            return True
        except OSError:
            pass
    shutil.copyfile(src, dst)
    return False
