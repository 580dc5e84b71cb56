"""HDRI discovery, shared by the driver and the Blender workers (no bpy import).

The available HDRIs are ``lighting.hdri_dir``'s .exr/.hdr files, or Blender's bundled studio lights.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from deformsim.errors import UserError
from deformsim.schema import shown

HDRI_SUFFIXES = (".exr", ".hdr")


def blender_hdri_dir() -> Path:
    """Blender's bundled studio-light HDRIs, found without importing bpy."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise UserError("the bpy package is not installed: cannot find Blender's HDRIs (set lighting.hdri_dir)")
    for root in spec.submodule_search_locations:
        found = sorted(Path(root).glob("*/datafiles/studiolights/world"))
        if found:
            return found[-1]
    raise UserError("Blender's studiolights/world folder was not found in the bpy package (set lighting.hdri_dir)")


def hdri_files(hdri_dir: Path | str | None) -> dict[str, Path]:
    """HDRI name (file stem) -> path; Blender's studio lights (*.exr) when ``hdri_dir`` is None."""
    if hdri_dir is None:
        files = {p.stem: p for p in sorted(blender_hdri_dir().glob("*.exr"))}
        if not files:
            raise UserError("no HDRI found in Blender's studio lights (set lighting.hdri_dir)")
        return files
    hdri_dir = Path(hdri_dir)
    if not hdri_dir.is_dir():
        raise UserError(f"lighting.hdri_dir {hdri_dir} is not a folder")
    files = sorted(p for p in hdri_dir.iterdir() if p.is_file() and p.suffix.lower() in HDRI_SUFFIXES)
    if not files:
        raise UserError(f"lighting.hdri_dir {hdri_dir} holds no .exr or .hdr file")
    stems = [p.stem for p in files]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise UserError(f"lighting.hdri_dir {hdri_dir}: several files named {', '.join(dup)} (rename one)")
    return {p.stem: p for p in files}


def list_hdris(hdri_dir: Path | str | None) -> list[str]:
    """Names of the available HDRIs, sorted: the names samples draw from and the workers' world loads."""
    return sorted(hdri_files(hdri_dir))


def drawn_hdris(hdri_dir: Path | str | None, names: list[str] | None = None) -> list[str]:
    """The HDRIs samples draw from: :func:`list_hdris`, or only ``names`` (``lighting.hdris``) of them, each checked."""
    have = list_hdris(hdri_dir)
    if names is None:
        return have
    unknown = [n for n in names if n not in have]
    if unknown:
        raise UserError(f"lighting.hdris: no HDRI named '{shown(unknown[0])}' (have: {', '.join(have)})")
    return sorted(set(names))
