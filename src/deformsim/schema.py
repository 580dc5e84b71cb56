"""What the config and the spec share: strict models of finite numbers, range types, bounded error lines, and
reading a YAML mapping safely.

A range is a ``[min, max]`` pair. The range types carry their bounds in ``Annotated`` metadata (:class:`Within`,
:class:`Above`), checked after the pair is parsed, and their errors name the field: ``fill: FractionRange | None``.
"""

from __future__ import annotations

import math
import reprlib
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import yaml
from pydantic import BaseModel, ConfigDict, Field, GetCoreSchemaHandler, ValidationError
from pydantic_core import core_schema

from deformsim.errors import UserError

Range = tuple[float, float]

MAX_SEED = 2**63 - 1  # a seed is stored in the manifest's int64 column and seeds numpy's generators (no negatives)
Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]

MAX_YAML_BYTES = 1 << 20  # a config or spec is a few kilobytes
MAX_YAML_NODES = 100_000  # values a YAML document may hold once its aliases are expanded


class StrictModel(BaseModel):
    """A model that refuses unknown keys (a typo in a YAML file is an error, not a silent default) and NaN or
    infinite numbers."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def check_range(v: Range, lo: float | None = None, hi: float | None = None, name: str = "",
                above: float | None = None) -> Range:
    """``v`` unchanged, or a ValueError naming the range when it holds NaN or infinity, is empty, leaves [lo, hi]
    or does not stay strictly above ``above`` (a size or ratio that must be positive)."""
    a, b = v
    what = f"{name} range {shown(list(v), 60)}".strip()
    if not all(math.isfinite(x) for x in v if isinstance(x, float)):  # an int is finite, and may exceed any float
        raise ValueError(f"{what} must hold finite numbers")
    if a > b:
        raise ValueError(f"{what} is empty (min > max)")
    if lo is not None and a < lo:
        raise ValueError(f"{what} is negative" if lo == 0 else f"{what} goes below {lo}")
    if above is not None and a <= above:
        raise ValueError(f"{what} must be above {above}")
    if hi is not None and b > hi:
        raise ValueError(f"{what} goes above {hi}")
    return v


def check_unique(names: list[str], what: str) -> None:
    """A ValueError naming, in order, the names given more than once ("duplicate WHAT names: a, b")."""
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"duplicate {what} names: {', '.join(dup)}")


class _Check:
    """``Annotated`` metadata whose ``check(value, field_name)`` runs on the parsed value."""

    def __get_pydantic_core_schema__(self, source: object, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        return core_schema.with_info_after_validator_function(
            lambda v, info: self.check(v, info.field_name or ""), handler(source))


@dataclass(frozen=True)
class Within(_Check):
    """A range with ``min <= max``, ``lo <= min``, ``max <= hi`` and ``min > above`` (each bound optional)."""

    lo: float | None = None
    hi: float | None = None
    above: float | None = None

    def check(self, v: Range, name: str) -> Range:
        return check_range(v, self.lo, self.hi, name, self.above)


@dataclass(frozen=True)
class Above(_Check):
    """A number above ``bound`` and at most ``hi``, or a range whose values all are."""

    bound: float
    hi: float | None = None

    def check(self, v: float | Range, name: str) -> float | Range:
        if isinstance(v, tuple):
            return check_range(v, hi=self.hi, name=name, above=self.bound)
        if isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"{name} {v} must be a finite number")
        if v <= self.bound:
            raise ValueError(f"{name} {v} must be above {self.bound}")
        if self.hi is not None and v > self.hi:
            raise ValueError(f"{name} {v} goes above {self.hi}")
        return v


@dataclass(frozen=True)
class NonEmpty(_Check):
    """A list with at least one item; ``message`` says what an empty one lacks."""

    message: str

    def check(self, v: list, name: str) -> list:
        if not v:
            raise ValueError(self.message)
        return v


FractionRange = Annotated[Range, Within(hi=1, above=0)]  # a share of something that is never empty: (0, 1]

_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxtuple, _SHORT.maxdict, _SHORT.maxset = 3, 6, 6, 6, 6
_SHORT.maxstring = _SHORT.maxother = _SHORT.maxlong = 60


def shown(value: object, width: int = 80) -> str:
    """``value`` as an error line shows it: text as it is, anything else as its repr, at most ``width``
    characters (a huge or deeply nested value is cut with ``...``)."""
    if isinstance(value, (str, Path)):
        return clip(str(value)[: width * 4], width)
    try:
        return clip(_SHORT.repr(value), width)
    except ValueError:  # an integer of more digits than Python converts to text
        return "a number too long to show"


def clip(text: str, width: int = 200) -> str:
    """``text`` on one line, cut to ``width`` characters with ``...``."""
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 3] + "..."


def first_error(exc: ValidationError, data: object) -> tuple[tuple, str, object]:
    """The most specific error of ``exc`` (the deepest in ``data``, the first of those): its location in ``data``
    (without the tags pydantic adds for the member of a union it tried), its message, clipped, and the value."""
    best: tuple[tuple, str, object] | None = None
    for err in exc.errors():
        loc: list = []
        node = data
        for p in err["loc"]:
            if isinstance(node, dict):  # a key, also a missing or an unknown one
                loc.append(p)
                node = node.get(p)
            elif isinstance(node, (list, tuple)) and isinstance(p, int):
                loc.append(p)
                node = node[p] if p < len(node) else None
        if best is None or len(loc) > len(best[0]):
            best = (tuple(loc), clip(err["msg"].removeprefix("Value error, ")), err.get("input"))
    return best


def load_yaml(text: str) -> object:
    """The YAML ``text`` parsed to plain values (never runs code); a :class:`yaml.YAMLError` when it is
    malformed, holds an integer too long to read, or expands past :data:`MAX_YAML_NODES` values through its
    aliases (a "billion laughs")."""
    loader = _CountingLoader(text)
    try:
        return loader.get_single_data()
    except ValueError as exc:  # an integer of more digits than Python converts
        raise yaml.YAMLError(clip(str(exc).split(";")[0], 120)) from None
    finally:
        loader.dispose()


class _CountingLoader(yaml.SafeLoader):
    """A safe loader that counts the values a document expands to (an alias counts its anchor's values again)
    while composing, before any of them is built."""

    def __init__(self, stream):
        super().__init__(stream)
        self._sizes: dict[int, int] = {}

    def compose_node(self, parent, index):
        alias = self.check_event(yaml.AliasEvent)
        node = super().compose_node(parent, index)
        if alias:
            size = self._sizes.get(id(node))
            if size is None:
                raise yaml.YAMLError(f"an alias refers to its own anchor (line {node.start_mark.line + 1})")
        elif isinstance(node, yaml.SequenceNode):
            size = 1 + sum(self._sizes[id(c)] for c in node.value)
        elif isinstance(node, yaml.MappingNode):
            _unique_keys(node)
            size = 1 + sum(self._sizes[id(k)] + self._sizes[id(v)] for k, v in node.value)
        else:
            size = 1
        if size > MAX_YAML_NODES:
            raise yaml.YAMLError(f"it expands to more than {MAX_YAML_NODES} values through its aliases")
        self._sizes[id(node)] = size
        return node


def _unique_keys(node: yaml.MappingNode) -> None:
    """A :class:`yaml.YAMLError` naming a key that ``node`` holds twice (YAML would keep the last one silently)."""
    seen = set()
    for key, _ in node.value:
        if isinstance(key, yaml.ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
            if (key.tag, key.value) in seen:
                raise yaml.YAMLError(f"the key {clip(key.value, 60)!r} appears twice in one mapping (line "
                                     f"{key.start_mark.line + 1}): keep one")
            seen.add((key.tag, key.value))


def read_mapping(path: Path, what: str) -> dict:
    """The YAML mapping in ``path`` (``what`` names it in errors: "config", "spec"); never runs code, and refuses
    a file over :data:`MAX_YAML_BYTES` or one whose aliases expand past :data:`MAX_YAML_NODES` values."""
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_YAML_BYTES + 1)
    except OSError as exc:
        raise UserError(f"{what} {path} cannot be read: {exc.strerror}") from None
    if len(raw) > MAX_YAML_BYTES:
        raise UserError(f"{what} {path} is larger than {MAX_YAML_BYTES >> 20} MiB: too large to be a {what}")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UserError(f"{what} {path} is not UTF-8 text (byte {exc.start}): save it as UTF-8") from None
    try:
        data = load_yaml(text)
    except yaml.YAMLError as exc:
        raise UserError(f"{what} {path} is not valid YAML: {clip(str(exc).splitlines()[0])}") from None
    except RecursionError:
        raise UserError(f"{what} {path} is nested too deeply to be a {what}") from None
    if data is None and what == "config":
        return {}
    if not isinstance(data, dict):
        raise UserError(f"{what} {path} must be a mapping, got {type(data).__name__}")
    return data
