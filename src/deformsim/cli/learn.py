"""``deformsim train``, ``predict`` and ``export``: torch is imported inside the Engine's methods only."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from deformsim.atomic import printable
from deformsim.cli.choices import config_choices, variant_choices
from deformsim.cli.common import ConfigArgs, console, err_console, fail_cleanly, from_config, plain_engine, set_option
from deformsim.errors import UserError
from deformsim.learn.backbones import BACKBONES


def train(
    data: Path = typer.Argument(..., help="generated dataset, or a folder with intact/ and deformed/ photos "
                                "(every image under each, subfolders included)"),
    out: Path = typer.Option(..., "--out", help="folder for model.pt and train.json"),
    variant: Optional[str] = typer.Option(None, autocompletion=variant_choices,
                                         help="image variant (default: the first of train.variants)"),
    epochs: Optional[int] = typer.Option(None, help=from_config("Training epochs", "train.epochs")),
    backbone: Optional[str] = typer.Option(None, autocompletion=config_choices("train.backbone"),
                                           help=from_config(f"Backbone: {', '.join(BACKBONES)}", "train.backbone")),
    weights: Optional[str] = typer.Option(None, autocompletion=config_choices("train.weights"), help=from_config(
        "Backbone weights: imagenet, offline or none", "train.weights")),
    device: Optional[str] = typer.Option(None, autocompletion=config_choices("train.device"),
                                         help=from_config("Training device: auto, cpu or cuda", "train.device")),
    target: Optional[str] = typer.Option(None, autocompletion=config_choices("train.target"), help=from_config(
        "What to learn: label (intact/deformed), or on a dataset generated with render.dense: severity (max "
        "displacement, mm), family (deformation kinds) or localise (deformed-region mask)", "train.target")),
    ensemble: Optional[int] = typer.Option(None, "--ensemble", help=from_config(
        "Models trained with consecutive seeds and saved as one that predicts their mean probability",
        "train.ensemble")),
    config: Optional[str] = typer.Option(None, "--config", "-c", help="YAML config file or preset name"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out trained with other settings"),
    adapt: Optional[Path] = typer.Option(
        None, "--adapt", help="unlabelled photos of real parts to adapt to (any folder; needs train.feature_norm)"
    ),
    set_: list[str] = set_option(),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while training."),
) -> None:
    """Train the deformation classifier (or a --target head) on a dataset variant (80/20 split, grouped by object).

    An existing model in --out is replaced only when it was trained with the same settings on the same images,
    or with --overwrite; the new one is built beside it and swapped in whole."""
    engine = ConfigArgs(config, {
        "--epochs": ("train.epochs", epochs), "--backbone": ("train.backbone", backbone),
        "--weights": ("train.weights", weights), "--device": ("train.device", device), "--target": ("train.target", target),
        "--ensemble": ("train.ensemble", ensemble),
    }, sets=set_).engine(progress)
    result = engine.train(data, out, variant, adapt, overwrite=overwrite)
    name, score, val_score = result.record.history[-1].scores()
    val = "" if val_score is None else f", validation {name} {val_score:.3f}"
    console.print(f"weights: {result.weights}", highlight=False)
    console.print(f"{result.images} images, {engine.config.train.epochs} epochs in {result.seconds:.1f} s: "
                  f"train {name} {score:.3f}{val}", highlight=False)
    console.print(f"saved {result.model_path}")


def predict(
    model_dir: Path = typer.Argument(..., help="folder with model.pt (or the file), or an exported .onnx"),
    images: list[Path] = typer.Argument(..., help="image files or folders"),
    csv: Optional[str] = typer.Option(None, "--csv", metavar="FILE", help="also write path,p_deformed,label to this CSV "
                                      "file; - writes it to stdout instead of the table"),
    json_: bool = typer.Option(False, "--json", help="print one JSON object per image (path and what the model "
                               "predicts) instead of the table"),
    threshold: Optional[float] = typer.Option(None, "--threshold", help="P(deformed) at or above this is labelled "
                                              "deformed (default: the model's own)"),
    adapt: bool = typer.Option(False, "--adapt", help="first adapt the model to these images (at least 8; no label "
                               "read), as deformsim adapt --method probe does, in memory"),
) -> None:
    """Print P(deformed) and the predicted label of each image (or what a --target model predicts), then how many
    are deformed."""
    if csv == "-" and json_:
        raise UserError("--csv - and --json both print to stdout: give one")
    to_file = Path(csv) if csv not in (None, "-") else None
    recipe = None
    if adapt:
        from deformsim.learn.adapter import AdaptRecipe

        recipe = AdaptRecipe()
    prediction = plain_engine().predict(model_dir, images, to_file, threshold=threshold, adapt=recipe)
    if prediction.prior is not None:
        err_console.print(f"adapted to these {len(prediction.paths)} images: an estimated {prediction.prior:.0%} of "
                          "them deformed", highlight=False, soft_wrap=True)
    if csv == "-":
        sys.stdout.write(prediction.frame().to_csv(index=False))
    elif json_:
        sys.stdout.write(prediction.frame().to_json(orient="records", lines=True))
    else:
        _print_rows(prediction)
    if prediction.threshold is not None:
        deformed = sum(p >= prediction.threshold for p in prediction.columns["p_deformed"])
        line = f"{deformed} deformed of {len(prediction.paths)} images (threshold {prediction.threshold:g})"
        (console if csv != "-" and not json_ and console.is_terminal else err_console).print(line, highlight=False)
    if to_file is not None:
        err_console.print(f"wrote {to_file}", highlight=False, soft_wrap=True)


def _print_rows(prediction) -> None:
    """A table on a terminal, numbers right-aligned; elsewhere one tab-separated line per image, with whole paths."""
    rows = [[printable(str(p)), *(v[i] if isinstance(v[i], str) else f"{v[i]:.4f}" for v in prediction.columns.values())]
            for i, p in enumerate(prediction.paths)]
    if not console.is_terminal:
        sys.stdout.write("".join("\t".join(row) + "\n" for row in rows))
        return
    table = Table("image")
    for heading, values in zip(prediction.headings, prediction.columns.values()):
        table.add_column(heading, justify="left" if values and isinstance(values[0], str) else "right")
    for row in rows:
        table.add_row(*row)
    console.print(table)


def export(
    model_dir: Path = typer.Argument(..., help="folder with model.pt (or the file)"),
    onnx: Path = typer.Option(..., "--onnx", help="output .onnx file"),
) -> None:
    """Export a trained model to ONNX (input: 0-1 RGB NCHW; output: P(deformed))."""
    console.print(f"wrote {plain_engine().export_onnx(model_dir, onnx)}")


def register(app: typer.Typer) -> None:
    for command in (train, predict, export):
        app.command()(fail_cleanly(command))
