"""Image files and class names, shared by every stage: which suffixes are images, what ``y`` means, and the one
function that reads an image file as pixels (:func:`open_rgb`), so training, prediction, evaluation and
background photos all see the same 8-bit sRGB RGB whatever the file's mode.
"""

from __future__ import annotations

from pathlib import Path

IMAGE_EXTS = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}
CLASSES = ("intact", "deformed")  # index = y
# how a labelled photo folder is read (dataset/real.py), said in every --help that takes one
REAL_RULE = ("DIR/intact/ and DIR/deformed/ (or good/ and defect/); every image under each, subfolders "
             "included, takes that folder's label")
LOADER_VERSION = 2  # bump when open_rgb's pixels change (the feature cache keys on it)


def images_in(folder: Path) -> list[Path]:
    """Image files under ``folder``, recursively, sorted."""
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in IMAGE_EXTS)


def open_rgb(path: str | Path, min_size: tuple[int, int] | None = None):
    """The image file at ``path`` as an 8-bit sRGB ``RGB`` PIL image: what every stage reads.

    - EXIF orientation is applied (the photo as a viewer shows it);
    - 16- and 32-bit integer greyscale keeps its high byte (as PIL reads 16-bit colour files); float images are
      read as 0-1, or as 0-255 or 0-65535 when their values go beyond that;
    - palette, greyscale, bilevel, YCbCr, CMYK and LAB images are converted, through their embedded ICC
      profile when there is one (any profile other than sRGB);
    - transparency (an alpha channel, a palette or colour key) is composited over black, the background of
      the ``black`` variant.

    ``min_size`` (w, h) lets a JPEG decode at a reduced size that still covers it. A :class:`UserError` names a
    file that cannot be read.
    """
    from PIL import Image, ImageOps, UnidentifiedImageError

    from deformsim.errors import UserError

    try:
        with Image.open(path) as im:
            if min_size is not None:
                w, h = im.size
                r = max(min_size[0] / w, min_size[1] / h, 1e-9)
                im.draft("RGB", (max(1, int(w * r) + 1), max(1, int(h * r) + 1)))
            im.load()
            return to_rgb(ImageOps.exif_transpose(im))
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:  # PIL raises these for bad files
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise UserError(f"cannot read image {path}: {reason}") from None
    except Image.DecompressionBombError as exc:
        raise UserError(f"cannot read image {path}: {exc}") from None


def to_rgb(im):
    """An open PIL image of any mode as 8-bit sRGB ``RGB`` (see :func:`open_rgb`)."""
    import numpy as np
    from PIL import Image

    mode = im.mode
    if mode.startswith("I;16") or mode == "I":
        a = np.asarray(im).astype(np.int64)
        return Image.fromarray((np.clip(a, 0, 65535) >> 8).astype(np.uint8), "L").convert("RGB")
    if mode == "F":
        a = np.nan_to_num(np.asarray(im, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        top = float(a.max()) if a.size else 0.0
        scale = 255.0 if top <= 1.0 else 1.0 if top <= 255.0 else 255.0 / 65535.0
        return Image.fromarray(np.clip(np.rint(a * scale), 0, 255).astype(np.uint8), "L").convert("RGB")
    if mode == "LAB":
        return _icc(im, _lab_profile(), "RGB")
    profile = im.info.get("icc_profile")
    if profile and mode in ("RGB", "RGBA", "CMYK"):
        converted = _from_profile(im, profile)
        if converted is not None:
            im, mode = converted, converted.mode
    if mode in ("RGBA", "LA", "PA", "La", "RGBa") or "transparency" in im.info:
        rgba = np.asarray(im.convert("RGBA"), dtype=np.uint32)
        a = rgba[..., 3:4]
        return Image.fromarray(((rgba[..., :3] * a + 127) // 255).astype(np.uint8), "RGB")
    return im if mode == "RGB" else im.convert("RGB")


def _from_profile(im, profile: bytes):
    """``im`` converted to sRGB through its embedded ICC profile; None when it is sRGB or unusable."""
    import io

    from PIL import ImageCms

    try:
        src = ImageCms.ImageCmsProfile(io.BytesIO(profile))
        if "srgb" in ImageCms.getProfileDescription(src).lower().replace(" ", ""):
            return None
        out_mode = "RGBA" if im.mode == "RGBA" else "RGB"
        return ImageCms.profileToProfile(im, src, ImageCms.createProfile("sRGB"), outputMode=out_mode)
    except (ImageCms.PyCMSError, OSError, ValueError):
        return None


def _lab_profile():
    from PIL import ImageCms

    return ImageCms.createProfile("LAB")


def _icc(im, src, out_mode: str):
    from PIL import ImageCms

    return ImageCms.profileToProfile(im, src, ImageCms.createProfile("sRGB"), outputMode=out_mode)
