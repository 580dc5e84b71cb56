"""Content identity: what an output was made from, named by the bytes of its inputs, never by paths or times.

A file's identity is the sha256 of its bytes. Within one process a digest is reused while the file's inode,
size, modification and change times are unchanged (the change time moves on every write, ``cp -p`` and
``touch -r`` included, and cannot be set back), so a command that reads an image several times hashes it once.
Nothing is remembered between processes: every command hashes what it reads.

The settings an output was made from are the config's fields, less those a :class:`Rule` marks as not changing
it (:func:`settings`); the rule is ``Annotated`` metadata on the field itself.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from pydantic import BaseModel

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
        h.update(f"{rel}\0{file_digest(path)}\n".encode("utf-8", "surrogateescape"))  # a name's bytes as they are
    return h.hexdigest()


def folder_digest(folder: str | Path) -> str:
    """Identity of every file under ``folder``: names and contents."""
    folder = Path(folder)
    return files_digest([p for p in folder.rglob("*") if p.is_file()], folder)


@dataclass(frozen=True)
class Rule:
    """How a config field counts in the identity of what is made from it; a field without a rule always counts.

    ``never``: it does not change the output (a worker count, a later stage's settings). ``when_set``: it counts
    only away from its default, so an option whose default changes nothing keeps every identity as it is.
    ``when``: it counts only while the sibling field ``when[0]`` holds the value ``when[1]``. ``content``: a path
    whose files the output's inputs name by their bytes; it counts as set or not, never by the path itself, so the
    same files reached by another path (relative or absolute, a moved folder) make the same output. Such a rule
    (:func:`by_content`) names the input: ``key``, its digest's name in what an output records; ``what``, in words;
    ``whole``: a folder read with everything under it.
    """

    never: bool = False
    when_set: bool = False
    when: tuple[str, object] | None = None
    content: bool = False
    key: str = ""
    what: str = ""
    whole: bool = False

    def counts(self, model: BaseModel, value: object, default: object) -> bool:
        if self.never or (self.when_set and value == default):
            return False
        return self.when is None or getattr(model, self.when[0]) == self.when[1]


ALWAYS = Rule()
NEVER = Rule(never=True)
WHEN_SET = Rule(when_set=True)


def by_content(key: str, what: str, whole: bool = False) -> Rule:
    """The rule of a path read by content: ``by_content("hdri", "HDRI folder")`` (see :class:`Rule`)."""
    return Rule(content=True, key=key, what=what, whole=whole)


def when(**sibling: object) -> Rule:
    """The rule of a field that counts only while one sibling field holds a value: ``when(mode="drop")``."""
    ((name, value),) = sibling.items()
    return Rule(when=(name, value))


def rule_of(model: type[BaseModel], name: str) -> Rule:
    """The :class:`Rule` of ``model``'s field ``name``."""
    return next((m for m in model.model_fields[name].metadata if isinstance(m, Rule)), ALWAYS)


def content_inputs(model: BaseModel) -> list[tuple[Rule, object]]:
    """The rule and value of every field read by content in ``model`` and the sections under it that are set, in
    field order."""
    out = []
    for name in type(model).model_fields:
        value, rule = getattr(model, name), rule_of(type(model), name)
        if rule.content:
            out.append((rule, value))
        elif isinstance(value, BaseModel):
            out.extend(content_inputs(value))
    return out


def settings(model: BaseModel) -> dict:
    """``model`` as JSON (``model_dump(mode="json")``) with only the fields that count by their rule, nested
    models walked alike."""
    return _counted(model, model.model_dump(mode="json"))


def _counted(model: BaseModel, dumped: dict) -> dict:
    out = {}
    for name, info in type(model).model_fields.items():
        value, rule = getattr(model, name), rule_of(type(model), name)
        if not rule.counts(model, value, info.default):
            continue
        if isinstance(value, BaseModel):
            out[name] = _counted(value, dumped[name])
        else:
            out[name] = "set" if rule.content and value is not None else dumped[name]
    return out
