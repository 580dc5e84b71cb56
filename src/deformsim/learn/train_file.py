"""``train.json``, what a training wrote beside its ``model.pt``, as a typed record (no torch here).

:func:`deformsim.learn.train.fit` writes it through :class:`TrainFile`; :func:`read_train` reads one back, or
refuses it in one line. A file written before the schema version (version 0.2.0) reads as version 1.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from pydantic import ConfigDict

from deformsim.records import Record, RecordFile, read_record


class Epoch(Record):
    """One epoch of a training's history: its loss and score on the training images and on those it held out for
    validation (None without any). A label model scores accuracy (``acc``); a head its ``metric`` (``score``)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=True, strict=True)  # a diverging loss is recorded as it is

    epoch: int
    loss: float
    acc: Optional[float] = None
    val_loss: Optional[float] = None
    val_acc: Optional[float] = None
    score: Optional[float] = None
    val_score: Optional[float] = None
    metric: Optional[str] = None
    seconds: float

    def scores(self) -> tuple[str, float, float | None]:
        """The name of the score, its value on the training images and on the validation images (None without)."""
        if self.metric is None:
            return "acc", self.acc, self.val_acc
        return self.metric, self.score, self.val_score


class HeldOut(Record):
    """The images a label model's training held out: their ids and P(deformed)."""

    ids: list[str]
    p_deformed: list[float]


class OutOfBag(Record):
    """An ensemble's (or a mixture's) scores on the images some member did not train on."""

    members: Optional[int] = None
    backbones: Optional[int] = None
    val_loss: Optional[float] = None
    val_acc: Optional[float]
    n_val: int


class Member(Record):
    """A further backbone of a mixture: what its own training recorded."""

    backbone: str
    weights: str
    history: list[Epoch]
    adapted: Optional[dict[str, Any]]
    ensemble: Optional[OutOfBag]


class TrainFile(RecordFile):
    """``train.json``."""

    WHAT = "training record (train.json)"

    weights: str
    seconds: float
    history: list[Epoch]
    n_train: int
    n_val: int
    adapted: Optional[dict[str, Any]] = None  # the unlabelled photos adapted to, and how
    ensemble: Optional[OutOfBag] = None
    held_out: Optional[HeldOut] = None
    config: dict[str, Any]  # the training settings (TrainConfig as JSON)
    mixture: Optional[list[Member]] = None
    mixture_validation: Optional[OutOfBag] = None


def read_train(path: str | Path) -> TrainFile:
    """The ``train.json`` at ``path`` (or in the model folder ``path``); one line naming the file when it is none."""
    path = Path(path)
    return read_record(path / "train.json" if path.is_dir() else path, TrainFile)
