"""``results.json``, the sim-to-real benchmark's file (:func:`deformsim.evaluate.benchmark.run_benchmark` and
``bench merge``, ``mean``, ``bag``), as a typed record: written through :class:`ResultsFile`, read by every command
that takes one (``bench compare``, ``merge``, ``mean``, ``bag`` and ``bench sim2real --baseline``) through
:func:`read_results`, before any work.

A file is refused in one line naming the first bad value when a key is missing, unknown or of another type, a
probability is NaN, infinite or outside [0, 1], the threshold is not in (0, 1), a run's predictions are not one per
photo, two runs share a variant and seeds, or the JSON is nested too deep to read. A file without ``schema_version``
(written before 2026-12-07) reads as version 1; the keys older writers left out (``plan``, ``variants``,
``ensembles``, ...) are those the commands do without. The settings are the config as the run dumped it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import ConfigDict, Field, StrictInt, StrictStr, model_validator

from deformsim.records import Record, RecordFile, read_record

SCHEMA_VERSION = 1

Probability = Annotated[float, Field(ge=0, le=1)]
Count = Annotated[StrictInt, Field(ge=0)]
Pair = Annotated[list[Count], Field(min_length=2, max_length=2)]


class Real(Record):
    """A run's metrics on the real photos."""

    accuracy: Probability
    f1: Probability
    precision: Probability
    recall: Probability
    auc: Optional[Probability] = None
    confusion: Annotated[list[Pair], Field(min_length=2, max_length=2)]  # [[TN, FP], [FN, TP]]


class Synthetic(Record):
    """A run's metrics on its held-out renders."""

    accuracy: Probability
    f1: Probability


class Run(Record):
    """One trained model's run: its variant and seeds, its model (several for a combined run) and metrics, and its
    prediction per photo."""

    variant: Annotated[StrictStr, Field(min_length=1)]
    data_seed: StrictInt
    composite_seed: Optional[StrictInt]
    train_seed: StrictInt
    model: Union[StrictStr, list[StrictStr]]
    real: Real
    synthetic: Synthetic
    real_predictions: list[Probability]

    def value(self, key: str) -> float | None:
        """A real metric (``accuracy``, ..., ``auc``) or a held-out one (``synthetic_accuracy``, ``synthetic_f1``)."""
        part = self.synthetic if key.startswith("synthetic_") else self.real
        return getattr(part, key.removeprefix("synthetic_"))

    def named(self) -> str:
        return (f"variant {self.variant}, data seed {self.data_seed}, background seed {self.composite_seed}, "
                f"training seed {self.train_seed}")


class Spreads(Record):
    """Mean and sample standard deviation of each real metric (NaN where a metric is undefined: AUC on one class;
    None: no AUC, in a file from before it, 2026-12-03)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=True, strict=True)

    accuracy_mean: float
    accuracy_std: float
    f1_mean: float
    f1_std: float
    precision_mean: float
    precision_std: float
    recall_mean: float
    recall_std: float
    auc_mean: Optional[float] = None
    auc_std: Optional[float] = None

    def spread(self, key: str) -> tuple[float, float]:
        """``<key>_mean`` and ``<key>_std``."""
        return getattr(self, f"{key}_mean"), getattr(self, f"{key}_std")


class Aggregate(Spreads):
    """A variant's runs: their number, and each real and held-out metric's mean and std over them."""

    n_runs: int
    synthetic_accuracy_mean: float
    synthetic_accuracy_std: float
    synthetic_f1_mean: float
    synthetic_f1_std: float


class Ensemble(Spreads):
    """A variant's ensembles (each draw's mean probability over its ``members`` training seeds), over its draws."""

    n_draws: int
    members: int


class Difference(Record):
    """A metric's mean paired difference and its 95 % interval; ``clears`` when the interval excludes zero."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=True, strict=True)

    diff: float
    low: float
    high: float
    clears: bool


class Comparison(Record):
    """A variant's paired differences to the baseline, per metric: run against run, ensemble against ensemble and
    ensemble against the baseline's single runs."""

    pairs: int
    baseline_variant: str
    runs: dict[str, Difference]
    ensemble: dict[str, Difference]
    ensemble_vs_single: dict[str, Difference]


class Baseline(Record):
    """The benchmark compared with (``results``, its path) and the comparison per variant."""

    results: str
    comparison: dict[str, Comparison]


class Plan(Record):
    """How the runs were made: the seeds and variants of a benchmark, or the inputs of a combined one (``merged``,
    ``mean of``, ``bagged``, with ``members`` per bag); ``whole``: its models trained on every render."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True, populate_by_name=True)

    data_seeds: Optional[int] = None
    composite_seeds: Optional[int] = None
    train_seeds: Optional[int] = None
    variants: Optional[list[str]] = None
    merged: Optional[list[str]] = None
    mean_of: Optional[list[str]] = Field(None, alias="mean of")
    bagged: Optional[list[str]] = None
    whole: bool = False
    members: Optional[int] = None


class _Open(Record):
    model_config = ConfigDict(extra="allow", allow_inf_nan=False, strict=True)


class Train(_Open):
    """The training settings (those the commands read typed; the rest kept as they are)."""

    threshold: Annotated[float, Field(gt=0, lt=1)]


class Settings(_Open):
    """The config the benchmark ran with, as it dumped it."""

    train: Train


class ResultsFile(RecordFile):
    """A benchmark's ``results.json``."""

    WHAT = "benchmark results file (results.json)"
    VERSION = SCHEMA_VERSION

    created: Optional[str] = None
    real_dir: StrictStr
    real_images: StrictInt
    real_paths: list[StrictStr]
    real_labels: list[Literal[0, 1]]  # for scoring and the reliability diagram only
    majority_baseline: Probability
    plan: Plan = Plan()
    adapt: Optional[str] = None
    settings: Settings
    variants: dict[str, Aggregate] = {}
    runs: Annotated[list[Run], Field(min_length=1)]
    ensembles: Optional[dict[str, Ensemble]] = None
    baseline: Optional[Baseline] = None
    seconds: float = 0.0

    @model_validator(mode="after")
    def _consistent(self) -> ResultsFile:
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

    @property
    def threshold(self) -> float:
        """The threshold the runs were scored at."""
        return self.settings.train.threshold

    def of(self, variant: str) -> list[Run]:
        """The runs of ``variant``."""
        return [r for r in self.runs if r.variant == variant]

    def config(self) -> dict[str, Any]:
        """The settings as the benchmark dumped them."""
        return self.settings.model_dump()


def read_results(path: str | Path) -> ResultsFile:
    """A benchmark's ``results.json`` (or the folder holding it); one line naming the file when it is none."""
    path = Path(path)
    return read_record(path / "results.json" if path.is_dir() else path, ResultsFile)
