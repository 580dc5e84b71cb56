"""Parameter records that serialise themselves: frozen dataclasses to plain dicts and back, by their type hints.

``to_dict`` is :func:`dataclasses.asdict` (tuples stay tuples), less the :func:`optional` fields that hold their
default; ``from_dict`` rebuilds nested records and tuples from the field types and leaves missing fields at their
defaults, so a record drawn before a field existed loads as it was.
"""

from __future__ import annotations

import types
import typing
from dataclasses import Field, field, fields
from functools import cache
from typing import Any, Self

_OPTIONAL = "deformsim.optional"


def optional(default: Any) -> Any:
    """A field the record leaves out while it holds ``default``."""
    return field(default=default, metadata={_OPTIONAL: True})


class Record:
    """Base of the parameter dataclasses: ``to_dict`` and ``from_dict`` for every field, nested records included."""

    def to_dict(self) -> dict:
        return {f.name: _dump(getattr(self, f.name)) for f in fields(self) if not _left_out(f, getattr(self, f.name))}

    @classmethod
    def from_dict(cls, d: dict) -> Self:
        hints = _hints(cls)
        return cls(**{k: _load(hints.get(k), v) for k, v in d.items()})


def _left_out(f: Field, value: Any) -> bool:
    return f.metadata.get(_OPTIONAL, False) and value == f.default


def _dump(v: Any) -> Any:
    if isinstance(v, Record):
        return v.to_dict()
    if isinstance(v, (tuple, list)):
        return type(v)(_dump(x) for x in v)
    if isinstance(v, dict):
        return {k: _dump(x) for k, x in v.items()}
    return v


def _load(tp: Any, v: Any) -> Any:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (types.UnionType, typing.Union):
        if v is None:
            return None
        (inner,) = (a for a in args if a is not type(None))
        return _load(inner, v)
    if isinstance(tp, type) and issubclass(tp, Record):
        return tp.from_dict(v)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_load(args[0], x) for x in v)
        return tuple(_load(a, x) for a, x in zip(args, v, strict=True))
    return v


@cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)
