"""Output paths: checked before any work starts, never silently replaced or mixed.

An output folder (a dataset, a model, a report) records what it was made from in ``inputs.json``. A command
writing into an existing one goes on only when it holds the same kind of output made with the same settings
and inputs; otherwise it stops with one line unless ``--overwrite`` is given, and then the new output is built
beside the old one and swapped in whole, so nothing of the old one is left. A folder that holds files but no
recognisable output is never replaced.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from deformsim.atomic import write_json
from deformsim.errors import ResourceError, UserError

INPUTS = "inputs.json"
# files that mark a folder as holding an output of each kind
MARKERS = {
    "dataset": ("config.yaml", "samples", "manifest.parquet"),
    "model": ("model.pt", "train.json", INPUTS),
    "report": ("metrics.json", "report.html", INPUTS),
}
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)


def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _check_writable_parent(path: Path, flag: str) -> None:
    """``path``'s folder exists or can be made, and files can be created there."""
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise UserError(f"{flag} {path}: {base} is a file, not a folder: choose another path")
    try:
        fd, probe = tempfile.mkstemp(prefix=".deformsim-write-test.", dir=base)
    except OSError as exc:
        raise UserError(f"{flag} {path}: cannot write in {base} ({exc.strerror}): choose another path") from None
    os.close(fd)
    os.unlink(probe)


def check_file_target(path: str | Path, flag: str) -> Path:
    """A file to be written: not a folder, under folders (not files), in a place where files can be created."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{flag} {path} is a folder: give the path of a file to write")
    _check_writable_parent(path, flag)
    return path


def check_folder_target(path: str | Path, flag: str, replace: bool = False) -> Path:
    """A folder to be written: not a file, under folders (not files), where files can be created (inside it when
    it exists; beside it too when it is to be ``replace``-d)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserError(f"{flag} {path} is a file, not a folder: choose a folder path")
    if path.is_dir():
        _check_writable_parent(path / "x", flag)  # where its files go
    if replace or not path.is_dir():
        _check_writable_parent(path, flag)  # where it is made, or built and swapped in
    return path


def holds(folder: Path, kind: str) -> bool:
    return any((folder / m).exists() for m in MARKERS[kind])


def _differences(a, b, prefix: str = "") -> list[tuple[str, object, object]]:
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)
                for d in _differences(a.get(k), b.get(k), f"{prefix}{k}.")]
    return [(prefix.rstrip(".") or "inputs", a, b)]


def _is_digest(v) -> bool:
    return isinstance(v, str) and len(v) >= 12 and all(c in "0123456789abcdef" for c in v)


def _first_difference(a, b) -> str:
    """The most readable difference: a changed setting before a changed content digest."""
    diffs = _differences(a, b)
    key, old, new = next((d for d in diffs if not (_is_digest(d[1]) or _is_digest(d[2]))), diffs[0])
    if _is_digest(old) and _is_digest(new):
        return f"{key}: other contents"
    return f"{key}: {_short(old)} there, {_short(new)} now"


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def read_inputs(folder: Path) -> dict | None:
    try:
        data = json.loads((Path(folder) / INPUTS).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def claim(out: str | Path, kind: str, identity: dict, overwrite: bool, flag: str = "--out") -> bool:
    """May a new ``kind`` made from ``identity`` go to ``out``? Checked before any work; True when one is there.

    A :class:`UserError` when ``out`` is a file, lies under a file or cannot be written; when it is a folder
    with files but no ``kind``; or when it holds a ``kind`` made from something else and ``overwrite`` is off.
    """
    out = check_folder_target(out, flag, replace=True)  # built beside it, then swapped in
    if not out.is_dir() or not any(out.iterdir()):
        return False
    if not holds(out, kind):
        raise UserError(f"{flag} {out} holds files but no deformsim {kind}: choose a new or empty folder "
                        "(it is never replaced)")
    if overwrite:
        return True
    old = read_inputs(out)
    if old is None:
        raise UserError(f"{flag} {out} holds a {kind} whose settings were not recorded: pass --overwrite to "
                        "replace it, or choose another folder")
    if old != {"kind": kind, **identity}:
        diff = _first_difference(old, {"kind": kind, **identity})
        raise UserError(f"{flag} {out} holds a {kind} made with other settings ({diff}): pass --overwrite to "
                        "replace it, or choose another folder")
    return True


def remove_folder(folder: Path) -> None:
    """Remove ``folder`` as a whole: renamed aside first, so it is gone at once whatever is interrupted."""
    folder = Path(folder)
    if not folder.exists():
        return
    trash = folder.parent / f".{folder.name}.removing-{uuid.uuid4().hex[:8]}"
    os.rename(folder, trash)
    shutil.rmtree(trash, ignore_errors=True)


@contextmanager
def replacing(out: str | Path, identity: dict | None = None, kind: str | None = None) -> Iterator[Path]:
    """Yield an empty staging folder beside ``out``; when the block succeeds it takes ``out``'s place whole.

    ``identity`` (with ``kind``) is recorded in ``inputs.json``. On failure (or Ctrl-C) the staging folder is
    removed and ``out`` is left as it was.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.staging-", dir=out.parent))
    try:
        yield staging
        if identity is not None:
            write_json(staging / INPUTS, {"kind": kind, **identity})
        old = None
        if out.exists():
            old = out.parent / f".{out.name}.old-{uuid.uuid4().hex[:8]}"
            os.rename(out, old)
        os.rename(staging, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def os_error_line(exc: OSError) -> tuple[str, int]:
    """One line (and the exit code) for an OSError that reached the command line."""
    where = f" ({exc.filename})" if exc.filename else ""
    if exc.errno in DISK_FULL:
        return f"{exc.strerror}{where}: free some disk space, then rerun the same command", ResourceError.exit_code
    return f"{exc.strerror or exc}{where}: check the path and its permissions", UserError.exit_code


def cache_dir() -> Path:
    """Where converted weights, feature caches and deformation banks live: ``$DEFORMSIM_CACHE`` or
    ``~/.cache/deformsim``."""
    return Path(os.environ.get("DEFORMSIM_CACHE") or Path.home() / ".cache" / "deformsim")
