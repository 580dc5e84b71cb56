"""Results files as typed records: one pydantic model per file, written and read through it, with a schema version.

A file is written as its model dumps it: the keys its writer set, and ``schema_version``. A file without
``schema_version`` (written before there was one) reads as version 1. A file that is no such record (not JSON, a
value of the wrong type, a key the model lacks, a newer ``schema_version``) is refused in one line naming the file.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Annotated, ClassVar, TypeVar

from pydantic import ConfigDict, Field, StrictInt, ValidationError

from deformsim.atomic import printable, write_json
from deformsim.errors import UserError
from deformsim.schema import StrictModel, first_error, shown

MAX_FILE = 256 << 20  # bytes of a results file (a report of a million predictions is ~100 MB)


class Record(StrictModel):
    """A part of a results file: known keys only, each of its type (a number is not read from text), finite."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


class RecordFile(Record):
    """A whole results file. Subclasses set :attr:`WHAT` (what the file is, for error lines) and :attr:`VERSION`."""

    WHAT: ClassVar[str] = "results file"
    VERSION: ClassVar[int] = 1
    schema_version: Annotated[StrictInt, Field(ge=1)] = 1

    def dump(self) -> dict:
        """The file's content: the keys set when it was made or read, and its schema version."""
        return self.model_dump(exclude_unset=True, by_alias=True) | {"schema_version": self.schema_version}

    def write(self, path: str | Path) -> None:
        """Write the record to ``path`` atomically."""
        write_json(path, self.dump())


R = TypeVar("R", bound=RecordFile)


def made(model: type[R], data: dict) -> R:
    """The record ``model`` of ``data`` (what a writer built) at the current schema version."""
    return model.model_validate({**data, "schema_version": model.VERSION}, strict=False)


def load_json(path: str | Path, name: str, refused: str, missing: str) -> tuple[bytes, object]:
    """The bytes of the JSON file ``path`` and what they parse to; else one line: ``NAME: no such file (MISSING)``,
    ``NAME cannot be read: ...`` or ``REFUSED: why`` (larger than :data:`MAX_FILE`, not JSON, nested too deeply)."""
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_FILE + 1)
    except FileNotFoundError:
        raise UserError(f"{name}: no such file ({missing})") from None
    except OSError as exc:
        raise UserError(f"{name} cannot be read: {exc.strerror}") from None
    if len(raw) > MAX_FILE:
        raise UserError(f"{refused}: larger than {MAX_FILE >> 20} MiB")
    try:
        return raw, json.loads(raw)
    except (ValueError, RecursionError) as exc:
        raise UserError(f"{refused}: {'nested too deeply' if isinstance(exc, RecursionError) else 'not JSON'}") from None


_LONE_SURROGATE = re.compile(rb"\\u[dD][89a-fA-F]")


def _printable(data):
    """``data`` with every string in :func:`deformsim.atomic.printable` form (a file name's non-UTF-8 bytes as ``\\xNN``)."""
    if isinstance(data, str):
        return printable(data)
    if isinstance(data, list):
        return [_printable(v) for v in data]
    if isinstance(data, dict):
        return {printable(k): _printable(v) for k, v in data.items()}
    return data


def read_record(path: str | Path, model: type[R], name: str | None = None) -> R:
    """The record ``model`` in the JSON file ``path``; one line naming the file (as ``name``, default its path) when
    it is none."""
    name = name or str(path)
    refused = f"{name} is not a deformsim {model.WHAT}"
    raw, data = load_json(path, name, refused, f"a {model.WHAT} was expected")
    if not isinstance(data, dict):
        raise UserError(f"{refused}: it holds {type(data).__name__} {shown(data, 40)}, not a JSON object")
    version = data.get("schema_version", 1)
    if type(version) is int and version > model.VERSION:
        raise UserError(f"{name} has schema_version {version}, newer than this deformsim reads ({model.VERSION}): "
                        "upgrade deformsim to read it")
    if _LONE_SURROGATE.search(raw):  # a non-UTF-8 file name, which json reads but pydantic's parser refuses
        raw = json.dumps(_printable(data)).encode()
    try:
        return model.model_validate_json(raw)
    except RecursionError:
        raise UserError(f"{refused}: nested too deeply") from None
    except ValidationError as exc:
        loc, msg, value = first_error(exc, data)
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in loc).lstrip(".") or "the file"
        got = "" if msg == "Field required" else f" (got {shown(value, 40)})"
        raise UserError(f"{refused}: {where}: {msg}{got}") from None
