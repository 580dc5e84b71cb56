"""The shooting session of each photo, so that no session lands on both sides of a validation split.

A photo's group is, in this order: the group a ``--groups`` CSV file gives it (``path,group`` rows, paths relative to
the file's folder or absolute), the date in its EXIF ``DateTimeOriginal``, or the date in its file name as phones
and cameras write it (``IMG_20220709_173654.jpg``, ``PXL_20230102_...``, ``2023-01-02 10.11.12.png``). A photo with
none of these is ``undated``; ``none`` puts every photo in one session.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

from deformsim.errors import UserError

UNDATED = "undated"
_NAME_DATE = re.compile(r"(?<!\d)(20\d\d)[-_.]?(0[1-9]|1[0-2])[-_.]?(0[1-9]|[12]\d|3[01])(?!\d)")
_EXIF_IFD, _DATE_TAKEN = 0x8769, 36867


def photo_date(path: str | Path) -> str:
    """``YYYY-MM-DD`` the photo was taken (EXIF, else its file name), or :data:`UNDATED`."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            taken = str(im.getexif().get_ifd(_EXIF_IFD).get(_DATE_TAKEN, ""))
    except (OSError, UnidentifiedImageError, ValueError):
        taken = ""
    if re.match(r"\d{4}:\d\d:\d\d", taken):
        return taken[:10].replace(":", "-")
    found = _NAME_DATE.search(Path(path).name)
    return "-".join(found.groups()) if found else UNDATED


def read_groups(file: Path) -> dict[str, str]:
    """``path -> group`` from a CSV file of ``path,group`` rows (resolved paths); one line naming a bad row."""
    file = Path(file)
    if not file.is_file():
        raise UserError(f"--groups file not found: {file}")
    groups = {}
    try:
        with open(file, newline="", encoding="utf-8") as fh:
            for n, row in enumerate(csv.reader(fh), 1):
                if not row or (n == 1 and [c.strip().lower() for c in row] == ["path", "group"]):
                    continue
                if len(row) != 2 or not row[0].strip() or not row[1].strip():
                    raise UserError(f"--groups {file} line {n}: expected 'path,group', got {','.join(row)!r}")
                groups[str((file.parent / row[0].strip()).resolve())] = row[1].strip()
    except UnicodeDecodeError:
        raise UserError(f"--groups {file} is not UTF-8 text") from None
    return groups


def photo_groups(paths: list[str], source: str = "date") -> list[str]:
    """The session of each of ``paths`` by ``source``: ``date`` (EXIF or file name), ``none`` (one session for all)
    or a ``path,group`` CSV file (its photos' groups; the others' dates)."""
    if source == "none":
        return ["all"] * len(paths)
    given = {} if source == "date" else read_groups(Path(source))
    return [given.get(str(Path(p).resolve())) or photo_date(p) for p in paths]
