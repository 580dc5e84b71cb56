"""The file a sim-to-real benchmark writes (``results.json``): one schema for every command that reads one
(``bench compare``, ``merge``, ``mean``, ``bag`` and ``bench sim2real --baseline``), checked before any work.

A file is refused in one line, naming the first bad value, when a key the commands read is missing or of another
type, a probability is NaN, infinite or outside [0, 1], the threshold is not in (0, 1), a run's predictions are not one
per photo, two runs share a variant and seeds, or the JSON is nested too deep to read. Keys the commands do not read
are kept as they are. ``schema_version`` is written since version 1; files without it (older ones) read as version 1.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, StrictInt, StrictStr, ValidationError, model_validator

from deformsim.errors import UserError
from deformsim.schema import first_error, shown

SCHEMA_VERSION = 1

Probability = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
Count = Annotated[StrictInt, Field(ge=0)]
Pair = Annotated[list[Count], Field(min_length=2, max_length=2)]


class _Part(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True)


class Real(_Part):
    """A run's metrics on the real photos."""

    accuracy: Probability
    f1: Probability
    precision: Probability
    recall: Probability
    auc: Optional[Probability] = None
    confusion: Annotated[list[Pair], Field(min_length=2, max_length=2)]  # [[TN, FP], [FN, TP]]


class Synthetic(_Part):
    """A run's metrics on its held-out renders."""

    accuracy: Probability
    f1: Probability


class Run(_Part):
    """One trained model's run: its variant and seeds, its model and metrics, and its prediction per photo."""

    variant: Annotated[StrictStr, Field(min_length=1)]
    data_seed: StrictInt
    composite_seed: Optional[StrictInt]
    train_seed: StrictInt
    model: Union[StrictStr, list[StrictStr]]
    real: Real
    synthetic: Synthetic
    real_predictions: list[Probability]

    def named(self) -> str:
        return (f"variant {self.variant}, data seed {self.data_seed}, background seed {self.composite_seed}, "
                f"training seed {self.train_seed}")


class _Train(_Part):
    threshold: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]


class _Settings(_Part):
    train: _Train


class Results(_Part):
    """What the commands read of a ``results.json``."""

    schema_version: Annotated[StrictInt, Field(ge=1, le=SCHEMA_VERSION)] = SCHEMA_VERSION
    real_dir: StrictStr
    real_images: StrictInt
    real_paths: list[StrictStr]
    real_labels: list[Literal[0, 1]]
    majority_baseline: Probability
    settings: _Settings
    runs: Annotated[list[Run], Field(min_length=1)]

    @model_validator(mode="after")
    def _consistent(self) -> Results:
        n = len(self.real_paths)
        if len(self.real_labels) != n or self.real_images != n:
            raise ValueError(f"real_paths, real_labels and real_images disagree ({n} paths, {len(self.real_labels)} "
                             f"labels, real_images {self.real_images})")
        seen: set[tuple] = set()
        for i, run in enumerate(self.runs):
            if len(run.real_predictions) != n:
                raise ValueError(f"runs[{i}] ({run.named()}) holds {len(run.real_predictions)} predictions for {n} "
                                 "photos")
            key = (run.variant, run.data_seed, run.composite_seed, run.train_seed)
            if key in seen:
                raise ValueError(f"runs[{i}] is a second run of {run.named()}: each run may appear once")
            seen.add(key)
        return self


def _where(loc: tuple) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in loc).lstrip(".")


def check_results(data: object, source: str) -> dict:
    """``data`` (a parsed ``results.json`` named ``source``) when it holds what the commands read; one line if not."""
    if not isinstance(data, dict):
        raise UserError(f"{source} holds no benchmark results (a JSON object), but {type(data).__name__} "
                        f"{shown(data, 40)}")
    try:
        Results.model_validate(data)
    except RecursionError:
        raise UserError(f"{source} is nested too deeply to be benchmark results") from None
    except ValidationError as exc:
        loc, msg, value = first_error(exc, data)
        if not loc:
            raise UserError(f"{source}: {msg}") from None
        got = "" if msg.startswith("Field required") else f" (got {shown(value, 40)})"
        raise UserError(f"{source}: {_where(loc)}: {msg}{got}") from None
    return data


def read_results(path: Path) -> dict:
    """A benchmark's ``results.json`` (or the folder holding it), checked by :class:`Results`; one line if not."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except RecursionError:
        raise UserError(f"cannot read benchmark results {path}: nested too deeply") from None
    except (OSError, ValueError) as exc:
        raise UserError(f"cannot read benchmark results {path}: {getattr(exc, 'strerror', None) or exc}") from None
    return check_results(data, str(path))
