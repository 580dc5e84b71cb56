"""What the shell completes an option's value to: the values a config key admits, the variants of the dataset on
the command line, the shells."""

from __future__ import annotations

import typing
from collections.abc import Callable

import typer

SHELLS = ("bash", "zsh", "fish", "powershell", "pwsh")


def completes(*values: str) -> Callable[[str], list[str]]:
    """A completion of ``values``: those that start as typed."""

    def complete(incomplete: str) -> list[str]:
        return [v for v in values if v.startswith(incomplete)]

    return complete


def export_formats(incomplete: str) -> list[str]:
    """A completion of ``export-data --format`` (the export package is imported only when asked)."""
    from deformsim.export import FORMATS

    return completes(*FORMATS)(incomplete)


def _literal(annotation) -> tuple[str, ...]:
    """The values of the first ``Literal`` in ``annotation`` (through ``Annotated``, ``Optional``, ``list``)."""
    if typing.get_origin(annotation) is typing.Literal:
        return tuple(map(str, typing.get_args(annotation)))
    for arg in typing.get_args(annotation):
        found = _literal(arg)
        if found:
            return found
    return ()


def config_values(key: str) -> tuple[str, ...]:
    """The values config key ``key`` (``"train.device"``) admits, by its type."""
    from pydantic import BaseModel

    from deformsim.config import Config

    model, annotation = Config, None
    for part in key.split("."):
        annotation = model.model_fields[part].annotation
        model = next((a for a in (annotation, *typing.get_args(annotation))
                      if isinstance(a, type) and issubclass(a, BaseModel)), None)
    return _literal(annotation)


def config_choices(key: str) -> Callable[[str], list[str]]:
    """A completion of the values config key ``key`` admits."""
    return completes(*config_values(key))


def _dataset(ctx: typer.Context) -> str | None:
    """The dataset folder on the command line being completed: its ``DATA`` argument or ``--data``, else (click
    leaves arguments unparsed while an option waits for its value) the first word that is a dataset folder."""
    import os
    import shlex
    from pathlib import Path

    if ctx.params.get("data"):
        return ctx.params["data"]
    line = os.environ.get("_TYPER_COMPLETE_ARGS") or os.environ.get("COMP_WORDS") or ""
    try:
        words = shlex.split(line)
    except ValueError:  # an open quote
        words = line.split()
    return next((w for w in words if (Path(w) / "manifest.parquet").is_file() or (Path(w) / "variants").is_dir()), None)


def _variants(ctx: typer.Context) -> list[str]:
    """The variants of the dataset named on the command line; the rendered ones without one."""
    from deformsim.dataset.layout import RENDER_KINDS

    rendered = [k for k in RENDER_KINDS if k != "rgba"]
    data = _dataset(ctx)
    if not data:
        return rendered
    from deformsim.dataset.variants import list_variants

    try:
        return list_variants(data)
    except OSError:  # an unreadable folder: only the rendered variants to offer
        return rendered


def variant_choices(ctx: typer.Context, incomplete: str) -> list[str]:
    """A completion of the variant of the dataset on the command line."""
    return [v for v in _variants(ctx) if v.startswith(incomplete)]


def variants_choices(ctx: typer.Context, incomplete: str) -> list[str]:
    """A completion of the last of comma-separated variants of the dataset on the command line."""
    done, _, last = incomplete.rpartition(",")
    prefix = f"{done}," if done else ""
    taken = set(done.split(","))
    return [prefix + v for v in _variants(ctx) if v.startswith(last) and v not in taken]
