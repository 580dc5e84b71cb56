"""`deformsim evaluate` (a trained model on a test set) and `deformsim report` (Table II + HTML report)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import console, fail_cleanly


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
        real: Optional[Path] = typer.Option(None, "--real", help="real photos (intact/ and deformed/) to test on"),
        threshold: Optional[float] = typer.Option(
            None, help="P(deformed) at or above this predicts deformed (default: the model's own)"
        ),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="write metrics and predictions to this JSON"),
    ) -> None:
        """Print a trained model's accuracy, F1, precision, recall and confusion matrix on a test set."""
        from deformsim.atomic import write_json
        from deformsim.evaluate.experiments import evaluate_model

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
        real: Optional[Path] = typer.Option(None, "--real", help="real photos (intact/ and deformed/) for sim-to-real"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="report folder (default: DATA/report)"),
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        variants: Optional[str] = typer.Option(None, help="comma-separated training variants, e.g. black,backgrounds"),
        epochs: Optional[int] = typer.Option(None, help="training epochs"),
        weights: Optional[str] = typer.Option(None, help="backbone weights: imagenet, offline or none"),
        progress: bool = typer.Option(True, "--progress/--no-progress"),
    ) -> None:
        """Train and test per variant (the paper's Table II) and write report.html and metrics.json."""
        from deformsim.config import load_config
        from deformsim.evaluate.experiments import run_experiments
        from deformsim.report.html import write_report

        names = [v.strip() for v in variants.split(",") if v.strip()] if variants is not None else None
        cfg = load_config(config, {"train.variants": names, "train.epochs": epochs, "train.weights": weights})
        out = out if out is not None else data / "report"
        metrics = run_experiments(data, cfg.train, out, real_dir=real, progress=progress)
        console.print(f"report: {write_report(metrics, out)}")
