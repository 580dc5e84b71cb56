"""What the config and the spec share: strict models, range checks, and reading a YAML mapping safely."""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ConfigDict

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
