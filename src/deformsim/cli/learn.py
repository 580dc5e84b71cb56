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
    target: Optional[str] = typer.Option(
        None, help="override train.target: label (intact/deformed), or on a dataset generated with render.dense: "
        "severity (max displacement, mm), family (deformation kinds) or localise (deformed-region mask)"
    ),
    config: Optional[str] = typer.Option(None, "--config", "-c", help="YAML config file or preset name"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace a model in --out trained with other settings"),
    adapt: Optional[Path] = typer.Option(
        None, "--adapt", help="unlabelled photos of real parts to adapt to (any folder; needs train.feature_norm)"
    ),
    progress: bool = typer.Option(True, "--progress/--no-progress"),
) -> None:
    """Train the deformation classifier (or a --target head) on a dataset variant (80/20 split, grouped by object).

    An existing model in --out is replaced only when it was trained with the same settings on the same images,
    or with --overwrite; the new one is built beside it and swapped in whole."""
    from deformsim.dataset.tables import load_table
    from deformsim.outputs import check_folder_target
    from deformsim.pipeline import train_model

    check_folder_target(out, "--out")
    cfg = load_cli_config(config, {"--epochs": ("train.epochs", epochs), "--backbone": ("train.backbone", backbone),
                                   "--weights": ("train.weights", weights), "--device": ("train.device", device),
                                   "--target": ("train.target", target)}).train
    table = load_table(data, variant, cfg.variants[0])
    result = train_model(table, cfg, out, data, variant or cfg.variants[0], overwrite=overwrite, progress=progress,
                         adapt=adapt)
    last = result.history[-1]
    name, key = ("acc", "acc") if cfg.target == "label" else (last["metric"], "score")
    val = "n/a" if last[f"val_{key}"] is None else f"{last[f'val_{key}']:.3f}"
    console.print(f"weights: {result.weights}")
    console.print(f"{len(table)} images, {cfg.epochs} epochs in {result.seconds:.1f} s: "
                  f"train {name} {last[key]:.3f}, validation {name} {val}")
    console.print(f"saved {result.model_path}")


def predict(
    model_dir: Path = typer.Argument(..., help="folder with model.pt (or the file)"),
    images: list[Path] = typer.Argument(..., help="image files or folders"),
    csv: Optional[Path] = typer.Option(None, "--csv", help="also write path,p_deformed,label to this CSV"),
) -> None:
    """Print P(deformed) and the predicted label of each image (or what a --target model predicts)."""
    from deformsim.dataset.real import expand_images
    from deformsim.learn.predict import load
    from deformsim.outputs import check_file_target

    if csv is not None:
        check_file_target(csv, "--csv")
    paths = expand_images(images)
    predictor = load(model_dir)
    if predictor.target == "label":
        proba, labels = predictor.predict(paths)
        columns = {"p_deformed": proba, "label": labels}
        heads = ("P(deformed)", "label")
    else:
        columns, heads = _target_columns(predictor, predictor.predict_outputs(paths))
    table = Table("image", *heads)
    for i, p in enumerate(paths):
        table.add_row(str(p), *(v[i] if isinstance(v[i], str) else f"{v[i]:.4f}" for v in columns.values()))
    console.print(table)
    if csv:
        import pandas as pd

        from deformsim.atomic import atomic_path

        with atomic_path(csv) as tmp:
            pd.DataFrame({"path": [str(p) for p in paths], **columns}).to_csv(tmp, index=False)
        console.print(f"wrote {csv}")


def _target_columns(predictor, out) -> tuple[dict, tuple]:
    """Per-image columns (CSV name -> values) and table headings of a severity, family or localise model's output."""
    if predictor.target == "severity":
        return {"max_disp_mm": out}, ("max displacement (mm)",)
    if predictor.target == "family":
        return {f"p_{n}": out[:, k] for k, n in enumerate(predictor.outputs)}, tuple(f"P({n})" for n in predictor.outputs)
    thr = predictor.cfg.threshold
    return ({"region_fraction": (out >= thr).mean(axis=(1, 2)), "peak": out.max(axis=(1, 2))},
            ("predicted region (share of image)", "peak P(region)"))


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
