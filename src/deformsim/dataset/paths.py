"""The files a dataset's manifests name: inside the dataset once symlinks are followed, and what they claim to be.

A manifest row naming ``/etc/hostname``, ``../x`` or a symlink that leads out of the dataset is refused with one
line naming the row and the file, and so is one that is not a regular file or, for an image, does not open as one.
This is the one place for that check, meant for every reader of a dataset's files: :func:`dataset_file` (or
:func:`dataset_files` for a table's column, :func:`dataset_resolver` for many files of one dataset) and
:func:`check_image`. A value that becomes part of a file name (an image's ``id``) is a plain name: :func:`file_stem`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from deformsim.errors import UserError
from deformsim.schema import shown


def dataset_file(root: str | Path, name: str | Path, what: str) -> Path:
    """``name`` (relative to the dataset ``root``, or absolute) with every symlink followed; a :class:`UserError`
    naming ``what`` (the row and column it comes from) when that lies outside ``root``. It need not exist."""
    return _inside(Path(root).resolve(), root, name, what)


def _inside(base: Path, root: str | Path, name: str | Path, what: str) -> Path:
    """:func:`dataset_file` under the already resolved ``base`` of ``root`` (resolved once for a whole column)."""
    if not isinstance(name, (str, Path)) or not str(name):
        raise UserError(f"{what}: {shown(name)} is not a file name")
    try:
        path = (base / name).resolve()
    except (OSError, RuntimeError, ValueError):  # a symlink loop, a NUL in the name
        raise UserError(f"{what}: {shown(name, 200)} cannot be resolved in the dataset {root} (a symlink loop or a "
                        "bad name)") from None
    if not path.is_relative_to(base):
        raise UserError(f"{what}: {shown(name, 200)} lies outside the dataset {root} (a path or symlink leading "
                        "out of it): every file a dataset names must be inside it")
    return path


def dataset_resolver(root: str | Path):
    """:func:`dataset_file` for many names of one dataset, its ``root`` resolved once: ``resolve(name, what)``."""
    base = Path(root).resolve()
    return lambda name, what: _inside(base, root, name, what)


MAX_STEM = 200  # characters of a name that becomes a file name (most filesystems allow 255 bytes)


def file_stem(value: object, what: str) -> str:
    """``value`` when it can name a file in a folder it is joined to: non-empty text without a folder separator,
    NUL or a ``.``/``..`` of its own, at most :data:`MAX_STEM` characters; a :class:`UserError` naming ``what``
    otherwise (an ``id`` of ``../../x`` or ``/etc/x`` would write outside the output)."""
    if not (isinstance(value, str) and value not in ("", ".", "..") and len(value) <= MAX_STEM
            and not any(c in value for c in "/\\\0")):
        raise UserError(f"{what}: {shown(value, 80)!r} is not a plain file name (no folders, '..', NUL, at most "
                        f"{MAX_STEM} characters)" if isinstance(value, str) else f"{what}: {shown(value, 80)} is not "
                        "text")
    return value


def dataset_files(root: str | Path, names: Iterable, what: Iterable[str]) -> list[str]:
    """:func:`dataset_file` of each name (with its ``what``), as strings: a table column's paths."""
    base = Path(root).resolve()
    return [str(_inside(base, root, n, w)) for n, w in zip(names, what)]


def check_image(path: str | Path, what: str) -> tuple[int, int]:
    """The ``(width, height)`` of the image file at ``path``; a :class:`UserError` naming ``what`` when it is not a
    regular file or does not open as an image."""
    from PIL import Image

    path = Path(path)
    if not path.is_file():
        raise UserError(f"{what}: {shown(path, 200)} is not a file")
    try:
        with Image.open(path) as im:
            return im.size
    except Exception as exc:  # PIL raises many kinds for a file that is not an image
        raise UserError(f"{what}: {shown(path, 200)} does not open as an image ({type(exc).__name__})") from None
