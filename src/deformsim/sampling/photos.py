"""The file-system read of sampling: the texture photos a surface may show."""

from __future__ import annotations

from pathlib import Path

from deformsim.dataset.images import IMAGE_EXTS, images_in
from deformsim.errors import UserError


def surface_photos(folder) -> list[str]:
    """The texture photos of ``render.surface.photos``, sorted (the draw picks by index); empty: a UserError."""
    root = Path(folder)
    if not root.is_dir():
        raise UserError(f"render.surface.photos: {root} is not a folder")
    found = [str(p) for p in images_in(root)]
    if not found:
        raise UserError(f"render.surface.photos: no images ({', '.join(sorted(IMAGE_EXTS))}) in {root}")
    return found
