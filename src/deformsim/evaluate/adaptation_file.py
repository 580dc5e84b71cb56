"""``bench adapt``'s ``adapt.json`` (:func:`deformsim.evaluate.adaptation.run_adaptation` writes and returns it; the
summary it prints reads it) as a typed record. A file without ``schema_version`` (written before 2026-12-07) reads
as version 1."""

from __future__ import annotations

from typing import Optional

from deformsim.evaluate.metrics_file import Interval, Scores
from deformsim.evaluate.results import Difference
from deformsim.learn.adapt_file import Recipe
from deformsim.records import Record, RecordFile


class Row(Record):
    """A method under a protocol (or the unadapted models): each model's scores, their mean and standard deviation
    (None where no model has the score), each model's P(deformed) per photo; adapted, the paired differences to the
    unadapted models per metric and the priors each model estimated (one per fold)."""

    models: list[Scores]
    accuracy: Optional[float]
    accuracy_std: Optional[float]
    f1: Optional[float]
    f1_std: Optional[float]
    auc: Optional[float]
    auc_std: Optional[float]
    predictions: list[list[float]]
    paired: Optional[dict[str, Difference]] = None
    prior: Optional[list[list[float]]] = None


class KshotRow(Record):
    """A curve at k labelled photos per class: mean accuracy over the runs, its standard deviation, and (but for the
    unadapted curve) the mean paired difference to the unadapted model with its 95 % interval."""

    k: int
    curve: str
    runs: int
    accuracy: float
    accuracy_std: float
    paired: Optional[float] = None
    paired_interval: Optional[Interval] = None


class UnlabelledRow(Record):
    """A method under a protocol, adapted on n unlabelled photos: mean accuracy over the runs, its standard deviation,
    the unadapted model's on the same photos, and the mean paired difference with its 95 % interval."""

    n: int
    curve: str
    runs: int
    accuracy: float
    accuracy_std: float
    unadapted: float
    paired: float
    paired_interval: Interval


class AdaptBenchFile(RecordFile):
    """``bench adapt``'s ``adapt.json``: the models, the photos with their labels and sessions, and the rows."""

    WHAT = "adaptation benchmark (bench adapt's adapt.json)"

    models: list[str]
    real: str
    photos: int
    folds: int
    seed: int
    recipe: Recipe
    true_share: float
    labels: list[int]
    groups: str
    biased: bool = False  # the k photos of each class drawn from a different lighting (bench adapt --biased)
    sessions: list[str]
    paths: list[str]
    rows: dict[str, Row]
    kshot: list[KshotRow]
    unlabelled: list[UnlabelledRow] = []  # bench adapt --n
    draws: int
    seconds: float
