"""Output paths: checked before any work starts, never silently replaced or mixed.

An output folder knows what it holds: a dataset, model or report names its kind in ``inputs.json`` (with what it
was made from), an export in ``export.json``; one made before kinds were recorded is known by its files
(:data:`SIGNS`). A command writing into an existing folder goes on only when it holds the same kind of output
made with the same settings and inputs; otherwise it stops with one line, naming what it found, unless
``--overwrite`` is given and the folder holds that kind and nothing else: then the new output is built beside
the old one and swapped in whole, so nothing of the old one is left. A folder holding another kind, or files but
no recognisable output, is never replaced, and no output folder is an input of the same command or holds one.
No output, and no file a command writes, lies inside another output (which would overwrite it, or remove it when
replaced); an output holding another one (made so by an older deformsim) is never replaced.
"""

from __future__ import annotations

import errno
import json
import os
import pwd
import re
import shutil
import tempfile
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterable, Iterator

from deformsim.atomic import write_json
from deformsim.errors import ResourceError, UserError
from deformsim.parallel import owner_gone, owner_tag
from deformsim.schema import shown

INPUTS = "inputs.json"
EXPORT = "export.json"
KINDS = ("dataset", "model", "report", "export")
# the files every output of a kind holds, by which one made before kinds were recorded is known
SIGNS = {"dataset": ("config.yaml", "samples"), "model": ("model.pt", "train.json"),
         "report": ("report.html", "metrics.json")}
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)
# what `replacing` and `remove_folder` leave beside a target when killed: `.NAME.staging-HOST-PID-START-XXXXXXXX`
# and the like, named by the process that works in it (:func:`deformsim.parallel.owner_tag`)
_LEFTOVER = re.compile(r"(staging|old|removing)-(.+)-[0-9a-f]{8}")


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


def output_above(path: str | Path) -> tuple[Path, str] | None:
    """The nearest folder above ``path`` (symlinks followed; not ``path`` itself) that holds a deformsim output, and
    its kind; None when there is none."""
    for folder in Path(path).resolve().parents:
        found = kinds_in(folder)
        if found:
            return folder, " and ".join(sorted(found))
    return None


def _check_not_inside_output(path: Path, flag: str, what: str) -> None:
    """A :class:`UserError` when ``path`` lies inside a deformsim output: it would go when that output is replaced
    (and a file there could overwrite one of the output's own)."""
    owner = output_above(path)
    if owner is not None:
        folder, kind = owner
        raise UserError(f"{flag} {path} lies inside the deformsim {kind} {folder}: {what} there could overwrite its "
                        "files and goes when it is replaced: choose a path outside it")


def check_file_target(path: str | Path, flag: str, inputs: Iterable[str | Path | None] = ()) -> Path:
    """A file to be written: not a folder, under folders (not files), in a place where files can be created, none
    of the command's ``inputs`` (a model folder stands for its ``model.pt``) and not inside a deformsim output
    (a dataset's ``manifest.parquet``, another model's ``model.pt``)."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{flag} {path} is a folder: give the path of a file to write")
    target = path.resolve()
    for source in inputs:
        if source is None:
            continue
        source = Path(source) / "model.pt" if Path(source).is_dir() else Path(source)
        if source.resolve() == target:
            raise UserError(f"{flag} {path} is an input of this command ({source}): choose another file")
    _check_not_inside_output(path, flag, "a file")
    _check_writable_parent(path, flag)
    return path


def check_folder_target(path: str | Path, flag: str, replace: bool = False) -> Path:
    """A folder to be written: not a file, not inside another deformsim output, under folders (not files), where
    files can be created (inside it when it exists; beside it too when it is to be ``replace``-d)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserError(f"{flag} {path} is a file, not a folder: choose a folder path")
    _check_not_inside_output(path, flag, "an output")
    if path.is_dir():
        _check_writable_parent(path / "x", flag)  # where its files go
    if replace or not path.is_dir():
        _check_writable_parent(path, flag)  # where it is made, or built and swapped in
    return path


def read_inputs(folder: Path) -> dict | None:
    return _read_dict(Path(folder) / INPUTS)


def _read_dict(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def kinds_in(folder: str | Path) -> set[str]:
    """The kinds of output ``folder`` holds: those its ``inputs.json`` and ``export.json`` name, and those whose
    :data:`SIGNS` are all there. More than one means a mixed folder, which nothing replaces."""
    folder = Path(folder)
    found = {k for k, files in SIGNS.items() if all((folder / f).exists() for f in files)}
    recorded = read_inputs(folder)
    if recorded is not None and recorded.get("kind") in KINDS:
        found.add(recorded["kind"])
    if (folder / EXPORT).is_file():
        found.add("export")
    return found


def nested_output(folder: str | Path) -> tuple[Path, str] | None:
    """The first output inside ``folder`` (not ``folder`` itself) that a command made as one (its ``inputs.json``
    names its kind, or an ``export.json``), and its kind; None when there is none. A report's own models are no
    such output."""
    folder = Path(folder)
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        if root == str(folder) or (INPUTS not in files and EXPORT not in files):
            continue
        recorded = read_inputs(Path(root))
        kind = recorded.get("kind") if recorded is not None else None
        if kind in KINDS or EXPORT in files:
            return Path(root), kind if kind in KINDS else "export"
    return None


def check_no_nested(out: str | Path, flag: str = "--out") -> None:
    """A :class:`UserError` when ``out``, about to be replaced whole, holds another output, which would go with it."""
    inner = nested_output(out)
    if inner is not None:
        raise UserError(f"{flag} {out} holds the deformsim {inner[1]} {inner[0]}, which replacing it would remove: move "
                        "that out first, or choose another folder")


def _article(kind: str) -> str:
    return "an" if kind[0] in "aeiou" else "a"


def check_kind(out: str | Path, kind: str, flag: str = "--out") -> bool:
    """May a ``kind`` go to ``out`` (a folder path already checked)? True when it holds one, False when it is new
    or empty; a :class:`UserError` naming what it holds otherwise (such a folder is never replaced)."""
    out = Path(out)
    if not out.is_dir() or not any(out.iterdir()):
        return False
    found = kinds_in(out)
    if found == {kind}:
        return True
    if not found:
        raise UserError(f"{flag} {out} holds files but no deformsim {kind}: choose a new or empty folder "
                        "(it is never replaced)")
    if len(found) == 1:
        what = f"a deformsim {found.pop()}"
    else:
        what = "the files of " + " and ".join(f"{_article(k)} {k}" for k in sorted(found))
    raise UserError(f"{flag} {out} holds {what}, not {_article(kind)} {kind}: choose a new or empty folder "
                    "(it is never replaced)")


def check_apart(out: str | Path, flag: str, inputs: dict[str, str | Path | None]) -> None:
    """A :class:`UserError` when an input (its description -> its path) is ``out`` or lies inside it: replacing
    ``out`` would remove it."""
    target = Path(out).resolve()
    for what, path in inputs.items():
        if path is None:
            continue
        source = Path(path).resolve()
        if source == target:
            raise UserError(f"{flag} {out} is the {what} {path}: choose an output folder outside it")
        if source.is_relative_to(target):
            raise UserError(f"{flag} {out} contains the {what} {path}, which replacing it would remove: choose an "
                            "output folder outside it")


def check_outside(out: str | Path, flag: str, folders: dict[str, str | Path | None]) -> None:
    """A :class:`UserError` when ``out`` is or lies inside a folder read whole (its description -> its path): what
    is written there would be read as input next time."""
    target = Path(out).resolve()
    for what, path in folders.items():
        if path is not None and target.is_relative_to(Path(path).resolve()):
            raise UserError(f"{flag} {out} is or lies inside the {what} {path}: choose an output folder outside it")


def differences(a, b, prefix: str = "") -> list[tuple[str, object, object]]:
    """Every leaf where the nested dicts ``a`` and ``b`` differ, as (dotted key, value in a, value in b), keys sorted."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)
                for d in differences(a.get(k), b.get(k), f"{prefix}{k}.")]
    return [(prefix.rstrip(".") or "inputs", a, b)]


def _is_digest(v) -> bool:
    return isinstance(v, str) and len(v) >= 12 and all(c in "0123456789abcdef" for c in v)


def first_difference(a, b) -> str:
    """The most readable difference: a changed setting before a changed content digest."""
    diffs = differences(a, b)
    key, old, new = next((d for d in diffs if not (_is_digest(d[1]) or _is_digest(d[2]))), diffs[0])
    if _is_digest(old) and _is_digest(new):
        return f"{key}: other contents"
    return f"{key}: {_short(old)} there, {_short(new)} now"


def _short(v) -> str:
    """A recorded value for an error line: a text quoted, anything else as :func:`shown` writes it."""
    return repr(shown(v, 58)) if isinstance(v, str) else shown(v, 60)


def claim(out: str | Path, kind: str, identity: dict, overwrite: bool, flag: str = "--out") -> bool:
    """May a new ``kind`` made from ``identity`` go to ``out``? Checked before any work; True when one is there.

    A :class:`UserError` when ``out`` is a file, lies under a file or inside another output, or cannot be written;
    when it is a folder with files but not a ``kind`` alone (:func:`check_kind`), or holds another output
    (:func:`check_no_nested`); or when it holds a ``kind`` made from something else and ``overwrite`` is off.
    """
    out = check_folder_target(out, flag, replace=True)  # built beside it, then swapped in
    if not check_kind(out, kind, flag):
        return False
    check_no_nested(out, flag)  # it is replaced whole, whatever is inside
    if overwrite:
        return True
    old = read_inputs(out)
    if old is None:
        raise UserError(f"{flag} {out} holds a {kind} whose settings were not recorded: pass --overwrite to "
                        "replace it, or choose another folder")
    if old != {"kind": kind, **identity}:
        diff = first_difference(old, {"kind": kind, **identity})
        raise UserError(f"{flag} {out} holds a {kind} made with other settings ({diff}): pass --overwrite to "
                        "replace it, or choose another folder")
    return True


def sweep(out: str | Path) -> None:
    """Remove what a killed :func:`replacing` or :func:`remove_folder` of ``out`` left beside it (its process is
    gone: :func:`~deformsim.parallel.owner_gone`, so never another host's): staging and half-removed folders go;
    the old folder of an interrupted swap is put back when ``out`` is missing."""
    out = Path(out)
    prefix = f".{out.name}."
    try:
        names = [p for p in out.parent.iterdir() if p.name.startswith(prefix)]
    except OSError:
        return
    for path in sorted(names):
        m = _LEFTOVER.fullmatch(path.name[len(prefix):])
        if m is None or not path.is_dir() or not owner_gone(m.group(2)):
            continue
        if m.group(1) == "old" and not out.exists():
            os.rename(path, out)
        else:
            shutil.rmtree(path, ignore_errors=True)


def _beside(out: Path, what: str) -> Path:
    return out.parent / f".{out.name}.{what}-{owner_tag()}-{uuid.uuid4().hex[:8]}"


def remove_folder(folder: Path) -> None:
    """Remove ``folder`` as a whole: renamed aside first, so it is gone at once whatever is interrupted."""
    folder = Path(folder)
    sweep(folder)
    if not folder.exists():
        return
    trash = _beside(folder, "removing")
    os.rename(folder, trash)
    shutil.rmtree(trash, ignore_errors=True)


@contextmanager
def replacing(out: str | Path, identity: dict | None = None, kind: str | None = None,
              keep: Callable[[], bool] | None = None) -> Iterator[Path]:
    """Yield an empty staging folder beside ``out``; when the block succeeds it takes ``out``'s place whole.

    ``identity`` (with ``kind``) is recorded in ``inputs.json``. On failure (or Ctrl-C) the staging folder is
    removed and ``out`` is left as it was; what a killed run left beside ``out`` is removed first (:func:`sweep`).
    ``keep``: asked when the block succeeds; True keeps ``out`` as it is (another process made it meanwhile).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    sweep(out)
    staging = _beside(out, "staging")
    staging.mkdir()
    try:
        yield staging
        if keep is not None and keep():
            return
        if identity is not None:
            write_json(staging / INPUTS, {"kind": kind, **identity})
        old = None
        if out.exists():
            old = _beside(out, "old")
            os.rename(out, old)
        os.rename(staging, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


@contextmanager
def locked(out: str | Path, what: str, flag: str = "--out") -> Iterator[None]:
    """Hold ``.NAME.lock`` beside ``out`` while the block runs: one writer at a time. The file names its holder's
    pid; its lock (``flock``) ends with the holder, so a lock left by a process that died is taken over. A
    :class:`UserError` naming the holder when a live process holds it."""
    import fcntl

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    path = out.parent / f".{out.name}.lock"
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise UserError(f"{flag} {out} is being written by another deformsim {what} (process {holder}, lock "
                            f"{path}): wait for it to end, or stop it first") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the holder removed it as we opened it: lock the new one
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        path.unlink(missing_ok=True)
        os.close(fd)


def os_error_line(exc: OSError) -> tuple[str, int]:
    """One line (and the exit code) for an OSError that reached the command line."""
    where = f" ({exc.filename})" if exc.filename else ""
    if exc.errno in DISK_FULL:
        return f"{exc.strerror}{where}: free some disk space, then rerun the same command", ResourceError.exit_code
    return f"{exc.strerror or exc}{where}: check the path and its permissions", UserError.exit_code


def _home() -> Path | None:
    """The user's home folder: ``$HOME`` when it is an absolute folder, else the passwd database's."""
    candidates = [os.environ.get("HOME") or ""]
    try:
        candidates.append(pwd.getpwuid(os.getuid()).pw_dir)
    except KeyError:  # no passwd entry for this uid (a container's --user)
        pass
    return next((Path(c) for c in candidates if os.path.isabs(c) and Path(c) != Path("/") and Path(c).is_dir()),
                None)


def cache_dir() -> Path:
    """Where converted weights, feature caches and deformation banks live, an absolute folder:
    ``$DEFORMSIM_CACHE`` (a relative one taken from the working folder), else ``$XDG_CACHE_HOME/deformsim``,
    else ``~/.cache/deformsim`` (the home of :func:`_home`)."""
    if os.environ.get("DEFORMSIM_CACHE"):
        return Path(os.environ["DEFORMSIM_CACHE"]).expanduser().absolute()
    xdg = os.environ.get("XDG_CACHE_HOME") or ""
    if os.path.isabs(xdg):  # a relative one is to be ignored (XDG base directory spec)
        return Path(xdg) / "deformsim"
    home = _home()
    if home is None:
        raise UserError(f"no folder for deformsim's cache: HOME is {_short(os.environ.get('HOME', ''))} and the user "
                        f"database names no home folder: set DEFORMSIM_CACHE to an absolute folder")
    return home / ".cache" / "deformsim"
