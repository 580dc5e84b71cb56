"""What the config and the spec share: strict models, range types, and reading a YAML mapping safely.

A range is a ``[min, max]`` pair. The range types carry their bounds in ``Annotated`` metadata (:class:`Within`,
:class:`Above`), checked after the pair is parsed, and their errors name the field: ``fill: FractionRange | None``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import yaml
from pydantic import BaseModel, ConfigDict, GetCoreSchemaHandler
from pydantic_core import core_schema

from deformsim.errors import UserError

Range = tuple[float, float]


class StrictModel(BaseModel):
    """A model that refuses unknown keys (a typo in a YAML file is an error, not a silent default)."""

    model_config = ConfigDict(extra="forbid")


def check_range(v: Range, lo: float | None = None, hi: float | None = None, name: str = "",
                above: float | None = None) -> Range:
    """``v`` unchanged, or a ValueError naming the range when it is empty, leaves [lo, hi] or does not stay
    strictly above ``above`` (a size or ratio that must be positive)."""
    a, b = v
    what = f"{name} range {list(v)}".strip()
    if a > b:
        raise ValueError(f"{what} is empty (min > max)")
    if lo is not None and a < lo:
        raise ValueError(f"{what} is negative" if lo == 0 else f"{what} goes below {lo}")
    if above is not None and a <= above:
        raise ValueError(f"{what} must be above {above}")
    if hi is not None and b > hi:
        raise ValueError(f"{what} goes above {hi}")
    return v


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
    """A number above ``bound``, or a range whose values all are."""

    bound: float

    def check(self, v: float | Range, name: str) -> float | Range:
        if isinstance(v, tuple):
            return check_range(v, name=name, above=self.bound)
        if v <= self.bound:
            raise ValueError(f"{name} {v} must be above {self.bound}")
        return v


@dataclass(frozen=True)
class NonEmpty(_Check):
    """A list with at least one item; ``message`` says what an empty one lacks."""

    message: str

    def check(self, v: list, name: str) -> list:
        if not v:
            raise ValueError(self.message)
        return v


OrderedRange = Annotated[Range, Within()]
NonNegativeRange = Annotated[Range, Within(0)]
PositiveRange = Annotated[Range, Within(above=0)]
FractionRange = Annotated[Range, Within(hi=1, above=0)]  # a share of something that is never empty: (0, 1]


def read_mapping(path: Path, what: str) -> dict:
    """The YAML mapping in ``path`` (``what`` names it in errors: "config", "spec"); never runs code."""
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UserError(f"{what} {path} is not UTF-8 text (byte {exc.start}): save it as UTF-8") from None
    except OSError as exc:
        raise UserError(f"{what} {path} cannot be read: {exc.strerror}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise UserError(f"{what} {path} is not valid YAML: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise UserError(f"{what} {path} is nested too deeply to be a {what}") from None
    if data is None and what == "config":
        return {}
    if not isinstance(data, dict):
        raise UserError(f"{what} {path} must be a mapping, got {type(data).__name__}")
    return data
