"""``bench ceiling``'s ``ceiling.json`` (:func:`deformsim.evaluate.ceiling.run_ceiling` writes and returns it; the
command prints it) as a typed record. A file without ``schema_version`` (written before 2026-12-07) reads as
version 1."""

from __future__ import annotations

from typing import Optional

from deformsim.records import Record, RecordFile


class CeilingRow(Record):
    """A backbone at an input size: where its weights came from, its feature count, the cross-validated scores
    (``auc`` None without both classes) and the seconds per photo its features took (stems cached by an earlier run
    are read, not computed; None in a file before 2026-12-07)."""

    backbone: str
    size: int
    weights: str
    features: int
    accuracy: float
    f1: float
    auc: Optional[float]
    seconds_per_photo: Optional[float] = None


class CeilingFile(RecordFile):
    """``bench ceiling``'s ``ceiling.json``: the folder, the cross-validation's settings, the majority-class share and
    a row per backbone and size."""

    WHAT = "real-to-real ceiling (bench ceiling's ceiling.json)"

    real: str
    photos: int
    folds: int
    l2: float
    seed: int
    majority: float
    rows: list[CeilingRow]
    seconds: float
