"""Content identity: what an output was made from, named by the bytes of its inputs, never by paths or times.

A file's identity is the sha256 of its bytes. Within one process a digest is reused while the file's inode,
size, modification and change times are unchanged (the change time moves on every write, ``cp -p`` and
``touch -r`` included, and cannot be set back), so a command that reads an image several times hashes it once.
Nothing is remembered between processes: every command hashes what it reads.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

_CHUNK = 1 << 20
_MEMO: dict[str, tuple[tuple, str]] = {}  # absolute path -> (stat key, sha256)


def digest(obj) -> str:
    """A short (12 hex) sha256 of ``obj`` as canonical JSON: the name of a setting or a set of inputs."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:12]


def _stat_key(st: os.stat_result) -> tuple:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def file_digest(path: str | Path) -> str:
    """sha256 (hex) of the file's bytes."""
    name = os.path.abspath(path)
    with open(name, "rb") as f:
        key = _stat_key(os.fstat(f.fileno()))
        memo = _MEMO.get(name)
        if memo is not None and memo[0] == key:
            return memo[1]
        h = hashlib.sha256()
        while chunk := f.read(_CHUNK):
            h.update(chunk)
    _MEMO[name] = (key, h.hexdigest())
    return h.hexdigest()


def files_digest(paths: list[str | Path], root: str | Path) -> str:
    """sha256 (hex) of the files' names relative to ``root`` and their bytes (the order does not matter)."""
    root = os.path.abspath(root)
    h = hashlib.sha256()
    for rel, path in sorted((Path(os.path.relpath(os.path.abspath(p), root)).as_posix(), p) for p in paths):
        h.update(f"{rel}\0{file_digest(path)}\n".encode())
    return h.hexdigest()


def folder_digest(folder: str | Path) -> str:
    """Identity of every file under ``folder``: names and contents."""
    folder = Path(folder)
    return files_digest([p for p in folder.rglob("*") if p.is_file()], folder)
