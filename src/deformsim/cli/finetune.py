"""``deformsim finetune``: a trained model adapted with a handful of labelled real photos."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import completes, variant_choices
from deformsim.cli.common import REAL_HELP, console, err_console, fail_cleanly, note, plain_engine


def finetune(
    model_dir: Path = typer.Argument(..., help="trained model folder (from deformsim train) or its model.pt"),
    real: Path = typer.Option(..., "--real", help=f"labelled real photos to adapt on: {REAL_HELP}"),
    out: Path = typer.Option(..., "--out", help="folder for the adapted model.pt and finetune.json"),
    data: Optional[Path] = typer.Option(None, "--data", help="generated dataset whose images are mixed into every "
                                        "batch so the model keeps what it learnt (with --variant)"),
    variant: Optional[str] = typer.Option(None, "--variant", autocompletion=variant_choices,
                                          help="image variant of --data (default: the one the "
                                          "model was trained on)"),
    part: str = typer.Option("tail", "--part", autocompletion=completes("head", "tail"), help="what trains: head, or "
                             "tail (the head and the backbone layers that training trained)"),
    steps: int = typer.Option(100, "--steps", help="optimiser steps"),
    lr: float = typer.Option(1e-4, "--lr", help="Adam learning rate (small: the model starts trained)"),
    views: int = typer.Option(4, "--views", help="augmented views of each photo, beside its plain image"),
    seed: int = typer.Option(0, "--seed", help="seed of the batches, the views and the dropout"),
    unlabelled: Optional[Path] = typer.Option(None, "--unlabelled", help="unlabelled photos of real parts (any folder, "
                                              "no label read) the fine-tuned model then adapts to, as deformsim "
                                              "adapt --photos does"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out made with other settings"),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
) -> None:
    """Adapt a trained model with labelled real photos (a small learning rate, augmented views, synthetic images
    mixed in with --data), then to unlabelled ones with --unlabelled; the adapted model refuses to be scored on the
    labelled photos (by content).

    An existing model in --out is replaced only when it was made with the same settings and inputs, or with
    --overwrite; the new one is built beside it and swapped in whole."""
    from deformsim.learn.finetune import Recipe

    recipe = Recipe(part=part, steps=steps, lr=lr, views=views, seed=seed)
    result = plain_engine(progress, notify=note(err_console)).finetune(model_dir, real, out, data, variant, recipe,
                                                                       overwrite=overwrite, unlabelled=unlabelled)
    mixed = f" and {result.synthetic} synthetic images" if result.synthetic else ""
    mixed += f", then to {result.unlabelled} unlabelled photos" if unlabelled is not None else ""
    console.print(f"adapted on {result.photos} photos{mixed} in {result.seconds:.1f} s: loss {result.loss[0]:.3f} -> "
                  f"{result.loss[1]:.3f}", highlight=False)
    console.print(f"saved {result.model_path}", highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    app.command()(fail_cleanly(finetune))
