"""The file-system read of sampling: the texture photos a surface may show, the artwork photos of a part."""

from __future__ import annotations

from pathlib import Path

from deformsim.dataset.images import IMAGE_EXTS, images_in
from deformsim.errors import UserError


def surface_photos(folder, what: str = "render.surface.photos") -> list[str]:
    """The texture photos of ``render.surface.photos`` (or the setting ``what``), sorted (the draw picks by index);
    empty: a UserError."""
    root = Path(folder)
    if not root.is_dir():
        raise UserError(f"{what}: {root} is not a folder")
    found = [str(p) for p in images_in(root)]
    if not found:
        raise UserError(f"{what}: no images ({', '.join(sorted(IMAGE_EXTS))}) in {root}")
    return found


def artwork_photos(folder) -> list[str]:
    """The artwork photos of ``render.appearance.photos``, sorted; a missing or empty folder: a UserError."""
    return surface_photos(folder, "render.appearance.photos")
