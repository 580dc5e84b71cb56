"""``metrics.json``, everything a report measured (:func:`deformsim.evaluate.experiments.run_experiments`), as a
typed record; and the scores of one test (:func:`deformsim.evaluate.metrics.compute_metrics`), which ``deformsim
evaluate`` returns too.

The report page, the end-of-run summary and ``deformsim run`` read a report through :func:`read_metrics`, which
refuses a file that is none in one line. A file written before the schema version (version 0.2.0) reads as
version 1. Keys an older writer left out are those the readers did without (``data``, ``plots``, ...).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal, Optional, Union

from deformsim.evaluate.fewshot_file import FewshotFile
from deformsim.learn.train_file import Epoch
from deformsim.records import Record, RecordFile, read_record

Interval = list[float]  # [low, high] of a 95 % interval


class Intervals(Record):
    accuracy: Optional[Interval] = None
    f1: Optional[Interval] = None
    precision: Optional[Interval] = None
    recall: Optional[Interval] = None


class Confusion(Record):
    matrix: list[list[int]]  # [[TN, FP], [FN, TP]]
    rows: list[str]
    cols: list[str]


class Scores(Record):
    """A binary test's scores (deformed is positive), as :func:`~deformsim.evaluate.metrics.compute_metrics` gives
    them: a ratio named in ``undefined`` has no denominator and is shown as "-"."""

    n: int
    n_deformed: int
    threshold: float
    accuracy: float
    precision: float
    recall: float
    f1: float
    auc: Optional[float] = None
    undefined: list[str] = []
    interval: Optional[Intervals] = None
    confusion: Confusion

    def value(self, key: str) -> float | None:
        """A score, or None when it is undefined (precision with no positive prediction, ...)."""
        return None if key in self.undefined else getattr(self, key)

    def interval_of(self, key: str) -> Interval | None:
        """A defined score's 95 % interval; None without one."""
        return getattr(self.interval, key) if self.interval is not None and self.value(key) is not None else None

    def baseline(self) -> float:
        """The accuracy of always answering the commoner label."""
        return max(self.n_deformed, self.n - self.n_deformed) / self.n


class Prediction(Record):
    path: str
    y: Literal[0, 1]
    prob: float


class Heatmap(Prediction):
    """A photo with its Grad-CAM overlay (``image``, relative to the report folder)."""

    image: str


class Example(Record):
    path: str
    y: Literal[0, 1]


class Counts(Record):
    n: int
    n_deformed: int
    n_samples: Optional[int] = None


class Experiment(Record):
    """A test that ran: a model trained on ``train`` and scored on ``test``."""

    train: Counts
    test: Counts
    model: str  # relative to the report folder
    weights: str
    history: list[Epoch]
    train_seconds: float
    predict_seconds: float
    metrics: Scores
    predictions: list[Prediction]
    gradcam: Optional[list[Heatmap]] = None


class Skipped(Record):
    """A test that could not run, and why."""

    skipped: str


class Summary(Record):
    accuracy: float
    f1: float
    precision: float
    recall: float


class Variant(Record):
    """A training variant's tests: ``split`` (held-out renders) and ``real`` (the real photos, when given)."""

    n_images: int
    n_samples: Optional[int] = None
    examples: list[Example] = []
    split: Optional[Union[Experiment, Skipped]] = None
    real: Optional[Union[Experiment, Skipped]] = None
    summary: Optional[dict[str, Optional[Summary]]] = None

    def ran(self, part: str) -> Experiment | None:
        """The test ``part`` ("split" or "real") when it ran."""
        test = getattr(self, part)
        return test if isinstance(test, Experiment) else None


class Plots(Record):
    pca_pixels: Optional[str] = None
    pca_features: dict[str, str] = {}


class Provenance(Record):
    """What the dataset was made from (records the report only shows; None where one was unreadable)."""

    config: Optional[dict[str, Any]] = None
    inputs: Optional[dict[str, Any]] = None
    composite: dict[str, dict[str, Any]] = {}


class Severity(Record):
    n: int
    mae_mm: float
    rmse_mm: float
    spearman: Optional[float]
    baseline_mae_mm: float


class Family(Record):
    ap: Optional[float]
    f1: float
    precision: float
    recall: float
    n_positive: int
    undefined: Optional[list[str]] = None

    def value(self, key: str) -> float | None:
        """F1, precision or recall; None where undefined (F1 and recall of a family no test image has)."""
        undefined = self.undefined if self.undefined is not None else ("f1", "recall") if not self.n_positive else ()
        return None if key in undefined else getattr(self, key)


class Families(Record):
    n: int
    threshold: float
    families: dict[str, Family]
    macro_ap: Optional[float]
    macro_f1: Optional[float]


class Region(Record):
    n: int
    threshold: float
    iou: float
    pixel_f1: float
    mean_iou: float
    truth_fraction: float
    predicted_fraction: float


class RealHeatmap(Record):
    path: str
    y: Literal[0, 1]
    image: str
    region_fraction: float
    peak: float


class Head(Record):
    """A dense-label head: its model, training time, outputs and scores on the held-out renders."""

    model: str
    train_seconds: float
    outputs: list[str]
    metrics: Union[Severity, Families, Region]
    plot: Optional[str] = None
    real_heatmaps: Optional[list[RealHeatmap]] = None


class Dense(Record):
    """The dense-label heads of one variant, or why they did not run (``skipped``)."""

    variant: str
    skipped: Optional[str] = None
    n_train: Optional[int] = None
    n_test: Optional[int] = None
    heads: dict[str, Head] = {}
    seconds: float = 0.0


class MetricsFile(RecordFile):
    """A report's ``metrics.json``."""

    WHAT = "report's metrics (metrics.json)"

    created: Optional[str] = None
    data_root: Optional[str] = None
    real_dir: Optional[str] = None
    real: Optional[Counts] = None
    settings: dict[str, Any]  # the training settings (TrainConfig as JSON)
    version: Optional[str] = None
    data: Provenance = Provenance()
    missing_variants: list[str] = []
    variants: dict[str, Variant]
    plots: Plots = Plots()
    seconds: float = 0.0
    dense: Optional[Dense] = None
    fewshot: Optional[FewshotFile] = None

    def results(self) -> list[tuple[str, str, Experiment]]:
        """(variant, part, test) of every test that ran."""
        return [(v, part, test) for v, e in self.variants.items() for part in ("split", "real")
                if (test := e.ran(part)) is not None]


class Evaluation(RecordFile):
    """What ``deformsim evaluate`` measured of a model on one test set (also written to its ``--out``)."""

    WHAT = "evaluation (deformsim evaluate --out)"

    model: str
    test: str
    n_images: int
    held_out: bool  # the model's held-out part of its training split
    metrics: Scores
    predictions: list[Prediction]


def read_metrics(path: str | Path) -> MetricsFile:
    """The ``metrics.json`` at ``path`` (or in the report folder ``path``); one line naming the file when it is none."""
    path = Path(path)
    return read_record(path / "metrics.json" if path.is_dir() else path, MetricsFile)
