"""``deformsim adapt``'s ``adapt.json``, written beside the adapted ``model.pt``
(:func:`deformsim.learn.adapt_stage.adapt_model`), as a typed record. A file without ``schema_version`` (written
before 2026-12-07) reads as version 1."""

from __future__ import annotations

from typing import Optional

from deformsim.records import Record, RecordFile


class Recipe(Record):
    """How the model adapted (:class:`deformsim.learn.adapter.AdaptRecipe`)."""

    method: str
    l2: float
    rounds: int
    labelled_weight: float
    steps: int = 200


class Folders(Record):
    """The folders of photos it adapted on (None: not given)."""

    photos: Optional[str]
    labelled: Optional[str]
    data: Optional[str] = None  # the renders a self-training method mixed in


class Choice(Record):
    """What a stacked model's cross-validation chose (:class:`deformsim.learn.stack.Choice`)."""

    l2: Optional[float]
    folds: int
    losses: dict[str, float]
    reason: str = ""


class AdaptFile(RecordFile):
    """A model's ``adapt.json``: the model adapted, on which photos and how, and what it judged before and after."""

    WHAT = "adaptation (deformsim adapt's adapt.json)"

    model: str
    groups: str
    recipe: Recipe
    folders: Folders
    protocol: str
    photos: int
    prior: float
    deformed_before: float
    deformed_after: float
    seconds: float
    labelled: int
    choice: Optional[Choice]
