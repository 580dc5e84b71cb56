"""``deformsim train``, ``predict`` and ``export``: torch is imported inside each command."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from deformsim.cli.common import console, fail_cleanly, load_cli_config


def train(
    data: Path = typer.Argument(..., help="generated dataset, or a folder with intact/ and deformed/ photos "
                                "(every image under each, subfolders included)"),
    out: Path = typer.Option(..., "--out", help="folder for model.pt and train.json"),
    variant: Optional[str] = typer.Option(None, help="image variant (default: the first of train.variants)"),
    epochs: Optional[int] = typer.Option(None, help="override train.epochs"),
    backbone: Optional[str] = typer.Option(None, help="override train.backbone (vgg16, mobilenet_v2)"),
    weights: Optional[str] = typer.Option(None, help="override train.weights (imagenet, offline, none)"),
    device: Optional[str] = typer.Option(None, help="override train.device (auto, cpu, cuda)"),
    config: Optional[str] = typer.Option(None, "--config", "-c", help="YAML config file or preset name"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out trained with other settings"),
    adapt: Optional[Path] = typer.Option(
        None, "--adapt", help="unlabelled photos of real parts to adapt to (any folder; needs train.feature_norm)"
    ),
    progress: bool = typer.Option(True, "--progress/--no-progress"),
) -> None:
    """Train the deformation classifier on a dataset variant (80/20 split, grouped by object).

    An existing model in --out is replaced only when it was trained with the same settings on the same images,
    or with --overwrite; the new one is built beside it and swapped in whole."""
    from deformsim.dataset.tables import load_table
    from deformsim.outputs import check_folder_target
    from deformsim.pipeline import train_model

    check_folder_target(out, "--out")
    cfg = load_cli_config(config, {"--epochs": ("train.epochs", epochs), "--backbone": ("train.backbone", backbone),
                                   "--weights": ("train.weights", weights), "--device": ("train.device", device)}).train
    table = load_table(data, variant, cfg.variants[0])
    result = train_model(table, cfg, out, data, variant or cfg.variants[0], overwrite=overwrite, progress=progress,
                         adapt=adapt)
    last = result.history[-1]
    val = "n/a" if last["val_acc"] is None else f"{last['val_acc']:.3f}"
    console.print(f"weights: {result.weights}")
    console.print(f"{len(table)} images, {cfg.epochs} epochs in {result.seconds:.1f} s: "
                  f"train acc {last['acc']:.3f}, validation acc {val}")
    console.print(f"saved {result.model_path}")


def predict(
    model_dir: Path = typer.Argument(..., help="folder with model.pt (or the file)"),
    images: list[Path] = typer.Argument(..., help="image files or folders"),
    csv: Optional[Path] = typer.Option(None, "--csv", help="also write path,p_deformed,label to this CSV"),
) -> None:
    """Print P(deformed) and the predicted label of each image."""
    from deformsim.dataset.real import expand_images
    from deformsim.learn.predict import load
    from deformsim.outputs import check_file_target

    if csv is not None:
        check_file_target(csv, "--csv")
    paths = expand_images(images)
    predictor = load(model_dir)
    proba, labels = predictor.predict(paths)
    table = Table("image", "P(deformed)", "label")
    for p, q, lab in zip(paths, proba, labels):
        table.add_row(str(p), f"{q:.4f}", lab)
    console.print(table)
    if csv:
        import pandas as pd

        from deformsim.atomic import atomic_path

        with atomic_path(csv) as tmp:
            pd.DataFrame({"path": [str(p) for p in paths], "p_deformed": proba, "label": labels}).to_csv(tmp, index=False)
        console.print(f"wrote {csv}")


def export(
    model_dir: Path = typer.Argument(..., help="folder with model.pt (or the file)"),
    onnx: Path = typer.Option(..., "--onnx", help="output .onnx file"),
) -> None:
    """Export a trained model to ONNX (input: 0-1 RGB NCHW; output: P(deformed))."""
    from deformsim.learn.export import to_onnx

    console.print(f"wrote {to_onnx(model_dir, onnx)}")


def register(app: typer.Typer) -> None:
    for command in (train, predict, export):
        app.command()(fail_cleanly(command))
