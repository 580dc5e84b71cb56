"""``deformsim adapt``: a trained model adapted to a folder of unlabelled photos of the user's parts."""

from __future__ import annotations

from pathlib import Path

import typer

from deformsim.cli.common import console, err_console, fail_cleanly, note, plain_engine

METHOD_HELP = ("probe: a logistic probe on the photos' frozen features, self-trained on the model's own "
               "judgements; prior: the share of deformed parts estimated by EM; probe+prior: both")


def adapt(
    model_dir: Path = typer.Argument(..., help="trained model folder (from deformsim train) or its model.pt"),
    photos: Path = typer.Option(..., "--photos", help="unlabelled photos of real parts (any folder, searched "
                                "recursively; no label is read), at least 8"),
    out: Path = typer.Option(..., "--out", help="folder for the adapted model.pt and adapt.json"),
    method: str = typer.Option("probe", "--method", help=METHOD_HELP),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out made with other settings"),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
) -> None:
    """Adapt a trained model to unlabelled photos of real parts; the model is scored on them only as transductive.

    An existing model in --out is replaced only when it was made with the same settings and inputs, or with
    --overwrite; the new one is built beside it and swapped in whole."""
    from deformsim.learn.adapter import AdaptRecipe

    result = plain_engine(progress, notify=note(err_console)).adapt(model_dir, photos, out, AdaptRecipe(method=method),
                                                                    overwrite=overwrite)
    console.print(f"adapted on {result.photos} photos in {result.seconds:.1f} s: an estimated {result.prior:.0%} "
                  f"deformed; judged deformed {result.deformed_before:.0%} before, {result.deformed_after:.0%} after",
                  highlight=False, soft_wrap=True)
    console.print(f"saved {result.model_path}", highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    app.command()(fail_cleanly(adapt))
