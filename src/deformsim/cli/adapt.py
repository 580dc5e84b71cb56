"""``deformsim adapt``: a trained model adapted to a folder of unlabelled photos of the user's parts."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import REAL_HELP, console, err_console, fail_cleanly, note, plain_engine

METHOD_HELP = ("probe: a logistic probe on the photos' frozen features, self-trained on the model's own "
               "judgements; prior: the share of deformed parts estimated by EM; probe+prior: both; stack: the model "
               "plus a residual fitted on the --labelled photos where their cross-validation says it helps; "
               "fixmatch, adamatch, mcc, cdan: the networks trained on the photos' strong views beside the renders of "
               "--data (pseudo-labels past FreeMatch's or AdaMatch's thresholds, minimum class confusion, or a "
               "conditional domain discriminator's reversed gradient) "
               "(default: stack with --labelled, else probe)")


def adapt(
    model_dir: Path = typer.Argument(..., help="trained model folder (from deformsim train) or its model.pt"),
    photos: Optional[Path] = typer.Option(None, "--photos", help="unlabelled photos of real parts (any folder, "
                                          "searched recursively; no label is read), at least 8"),
    out: Path = typer.Option(..., "--out", help="folder for the adapted model.pt and adapt.json"),
    labelled: Optional[Path] = typer.Option(None, "--labelled", help=f"labelled photos of real parts: {REAL_HELP}; "
                                            "the adapted model refuses to be scored on them"),
    groups: str = typer.Option("date", "--groups", help="shooting sessions of the --labelled photos, kept apart by "
                               "the stack's cross-validation: date (EXIF or file name), none, or a path,group CSV file"),
    method: Optional[str] = typer.Option(None, "--method", help=METHOD_HELP, show_default=False),
    data: Optional[Path] = typer.Option(None, "--data", help="fixmatch, adamatch, mcc, cdan: the dataset the model "
                                        "was trained on (its renders are mixed in)"),
    variant: Optional[str] = typer.Option(None, "--variant", help="fixmatch, adamatch, mcc, cdan: the variant of "
                                          "--data (default: the one the model was trained on)", show_default=False),
    steps: int = typer.Option(200, "--steps", help="fixmatch, adamatch, mcc, cdan: training steps of each network"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out made with other settings"),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
) -> None:
    """Adapt a trained model to photos of real parts: unlabelled (--photos; scoring the model on them is
    transductive), labelled (--labelled), or both.

    An existing model in --out is replaced only when it was made with the same settings and inputs, or with
    --overwrite; the new one is built beside it and swapped in whole."""
    from deformsim.learn.adapter import AdaptRecipe

    recipe = AdaptRecipe(method=method or ("stack" if labelled is not None else "probe"), steps=steps)
    result = plain_engine(progress, notify=note(err_console)).adapt(model_dir, photos, out, recipe, overwrite=overwrite,
                                                                    labelled=labelled, groups=groups, data=data,
                                                                    variant=variant)
    console.print(f"adapted on {result.photos} photos ({result.labelled} labelled) in {result.seconds:.1f} s: an "
                  f"estimated {result.prior:.0%} deformed; judged deformed {result.deformed_before:.0%} before, "
                  f"{result.deformed_after:.0%} after", highlight=False, soft_wrap=True)
    if result.choice is not None:
        console.print(stack_line(result.choice), highlight=False, soft_wrap=True)
    console.print(f"saved {result.model_path}", highlight=False, soft_wrap=True)


def stack_line(choice) -> str:
    """What the stack's cross-validation chose, in one line."""
    if choice.l2 is None and choice.reason:
        return f"kept the synthetic model as it is: {choice.reason}"
    losses = ", ".join(f"{k} {v:.3f}" for k, v in choice.losses.items())
    chose = "no residual" if choice.l2 is None else f"a residual with L2 penalty {choice.l2:g}"
    return f"cross-validation over {choice.folds} folds chose {chose} (held-out log-loss: {losses})"


def register(app: typer.Typer) -> None:
    app.command()(fail_cleanly(adapt))
