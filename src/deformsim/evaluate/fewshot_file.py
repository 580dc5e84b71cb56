"""``bench fewshot``'s ``fewshot.json`` as a typed record (:mod:`deformsim.evaluate.fewshot` writes and reads it; a
report shows it). A file without ``schema_version`` (written before 2026-12-07) reads as version 1."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from deformsim.records import Record, RecordFile

CURVES = ("synthetic", "unadapted", "imagenet")
Share = Annotated[float, Field(ge=0, le=1)]
Count = Annotated[int, Field(ge=0, le=10**9)]


class CurveRow(Record):
    """One k of a curve: the mean scores over its runs, their 95 % intervals, the majority-class share."""

    k: Count
    runs: Annotated[int, Field(ge=1, le=10**9)]
    interval: Annotated[str, Field(max_length=20)] | None = None  # what the interval resamples: photos, draws, seeds
    majority: Share
    accuracy: Share
    f1: Share
    accuracy_interval: tuple[Share, Share]
    f1_interval: tuple[Share, Share]


class Photos(Record):
    intact: Count
    deformed: Count


class FewshotFile(RecordFile):
    """``bench fewshot``'s ``fewshot.json``: what the report shows typed exactly; the rest of what it records
    may be missing (an older file) but has its type."""

    WHAT = "few-shot result (bench fewshot's fewshot.json)"

    kind: Literal["fewshot"]
    real_dir: Annotated[str, Field(max_length=4096)]
    model: Annotated[str, Field(max_length=4096)]
    majority_baseline: Share
    photos: Photos
    draws: Annotated[int, Field(ge=1, le=1000)]
    seeds: Annotated[int, Field(ge=1, le=1000)]
    curves: Annotated[dict[Literal[CURVES], Annotated[list[CurveRow], Field(min_length=1)]], Field(min_length=1)]
    created: str | None = None
    backbone: str | None = None
    weights: dict[str, str] | None = None
    ks: list[Count] | None = None
    capped: list[Count] | None = None
    biased: bool = False  # each class's k photos drawn from a different lighting (bench fewshot --biased)
    recipe: dict[str, object] | None = None
    data: str | None = None
    variant: str | None = None
    runs: list[dict[str, object]] | None = None
    seconds: Annotated[float, Field(ge=0)] | None = None
