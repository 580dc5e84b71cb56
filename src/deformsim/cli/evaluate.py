"""`deformsim evaluate` (a trained model on a test set) and `deformsim report` (Table II + HTML report)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import REAL_HELP, console, err_console, fail_cleanly, load_cli_config


def _print_metrics(title: str, m: dict) -> None:
    from rich.table import Table

    t = Table(title=title, show_header=True, header_style="bold")
    for col in ("images", "accuracy", "F1", "precision", "recall", "TN FP / FN TP"):
        t.add_column(col, justify="right")
    (tn, fp), (fn, tp) = m["confusion"]["matrix"]
    t.add_row(str(m["n"]), *(f"{100 * m[k]:.1f}%" for k in ("accuracy", "f1", "precision", "recall")),
              f"{tn} {fp} / {fn} {tp}")
    console.print(t)


def register(app: typer.Typer) -> None:
    @app.command("evaluate")
    @fail_cleanly
    def evaluate(
        model_dir: Path = typer.Argument(..., help="trained model folder (from deformsim train or report)"),
        data: Optional[Path] = typer.Option(None, "--data", help="generated dataset to test on (with --variant)"),
        variant: Optional[str] = typer.Option(None, "--variant", help="image variant of --data, e.g. black"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos to test on: {REAL_HELP}"),
        threshold: Optional[float] = typer.Option(
            None, help="P(deformed) at or above this predicts deformed (default: the model's own)"
        ),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="write metrics and predictions to this JSON"),
    ) -> None:
        """Print a trained model's accuracy, F1, precision, recall and confusion matrix on a test set."""
        from deformsim.atomic import write_json
        from deformsim.evaluate.experiments import evaluate_model
        from deformsim.outputs import check_file_target

        if out is not None:
            check_file_target(out, "--out")
        if real is not None:
            _found(real)
        what = real if real is not None else f"{data} / {variant}"
        err_console.print(f"testing {model_dir} on {what} (a progress bar follows on a terminal)",
                          highlight=False, soft_wrap=True)
        result = evaluate_model(model_dir, data, variant, real, threshold)
        part = " (held-out part of its training split)" if result["held_out"] else ""
        _print_metrics(f"{model_dir} on {result['test']}{part}", result["metrics"])
        if out is not None:
            write_json(out, result)
            console.print(f"metrics: {out}")

    @app.command("report")
    @fail_cleanly
    def report(
        data: Path = typer.Argument(..., help="generated dataset folder"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos for sim-to-real: {REAL_HELP}"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="report folder (default: DATA/report)"),
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        variants: Optional[str] = typer.Option(None, help="comma-separated training variants, e.g. black,backgrounds"),
        epochs: Optional[int] = typer.Option(None, help="training epochs"),
        weights: Optional[str] = typer.Option(None, help="backbone weights: imagenet, offline or none"),
        overwrite: bool = typer.Option(False, "--overwrite", help="replace a report in --out made with other settings"),
        progress: bool = typer.Option(True, "--progress/--no-progress"),
    ) -> None:
        """Train and test per variant (the paper's Table II) and write report.html and metrics.json.

        An existing report in --out is replaced only when it was made with the same settings and inputs, or with
        --overwrite; the new one is built beside it and swapped in whole (no old models or plots are left)."""
        from deformsim.outputs import check_folder_target
        from deformsim.pipeline import make_report

        out = out if out is not None else data / "report"
        check_folder_target(out, "--out")
        names = [v.strip() for v in variants.split(",") if v.strip()] if variants is not None else None
        cfg = load_cli_config(config, {"--variants": ("train.variants", names), "--epochs": ("train.epochs", epochs),
                                       "--weights": ("train.weights", weights)})
        if real is not None:
            _found(real)
        path = make_report(data, cfg.train, out, real=real, overwrite=overwrite, progress=progress)
        console.print(f"report: {path}")


def _found(real: Path) -> None:
    """Say what a labelled photo folder holds, where (the folder rule is in --help)."""
    from deformsim.dataset.real import describe, real_table

    err_console.print(f"real photos in {describe(real_table(real), real)}", highlight=False, soft_wrap=True)
