"""`deformsim evaluate` (a trained model on a test set) and `deformsim report` (Table II + HTML report)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Optional

import typer

from deformsim.cli.choices import config_choices, variant_choices, variants_choices
from deformsim.cli.common import (
    REAL_HELP,
    ConfigArgs,
    console,
    err_console,
    fail_cleanly,
    from_config,
    note,
    plain_engine,
    set_option,
)
from deformsim.cli.summary import metric_cell, print_table, report_summary

if TYPE_CHECKING:
    from deformsim.evaluate.metrics_file import Scores


def _print_metrics(title: str, m: Scores) -> None:
    from rich.table import Table

    t = Table(title=f"{title} (95 % intervals)", show_header=True, header_style="bold")
    for col in ("images", "accuracy", "F1", "precision", "recall", "TN FP / FN TP"):
        t.add_column(col, justify="right")
    (tn, fp), (fn, tp) = m.confusion.matrix
    t.add_row(str(m.n), *(metric_cell(m, k) for k in ("accuracy", "f1", "precision", "recall")),
              f"{tn} {fp} / {fn} {tp}")
    print_table(t)


def register(app: typer.Typer) -> None:
    @app.command("evaluate")
    @fail_cleanly
    def evaluate(
        model_dir: Path = typer.Argument(..., help="trained model folder (from deformsim train or report)"),
        data: Optional[Path] = typer.Option(None, "--data", help="generated dataset to test on (with --variant)"),
        variant: Optional[str] = typer.Option(None, "--variant", autocompletion=variant_choices,
                                              help="image variant of --data, e.g. black"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos to test on: {REAL_HELP}"),
        threshold: Optional[float] = typer.Option(
            None, help="P(deformed) at or above this predicts deformed (default: the model's own)"
        ),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="write metrics and predictions to this JSON"),
    ) -> None:
        """Print a trained model's accuracy, F1, precision, recall and confusion matrix on a test set."""
        engine = plain_engine(notify=note(err_console))
        result = engine.evaluate(model_dir, data, variant, real, threshold, out=out)
        part = " (held-out part of its training split)" if result.held_out else ""
        _print_metrics(f"{model_dir} on {result.test}{part}", result.metrics)
        if out is not None:
            console.print(f"metrics: {out}")

    @app.command("report")
    @fail_cleanly
    def report(
        data: Path = typer.Argument(..., help="generated dataset folder"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos for sim-to-real: {REAL_HELP}"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="report folder (default: DATA-report beside the dataset)"),
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        variants: Optional[str] = typer.Option(None, autocompletion=variants_choices,
                                               help=from_config("Comma-separated training variants",
                                                                      "train.variants")),
        epochs: Optional[int] = typer.Option(None, help=from_config("Training epochs", "train.epochs")),
        weights: Optional[str] = typer.Option(None, autocompletion=config_choices("train.weights"),
                                              help=from_config("Backbone weights: imagenet, offline or none",
                                                                     "train.weights")),
        overwrite: bool = typer.Option(False, "--overwrite", help="replace a report in --out made with other settings"),
        fewshot: Optional[Path] = typer.Option(None, "--fewshot", help="the fewshot.json of deformsim bench "
                                               "fewshot, whose curves the report shows"),
        set_: list[str] = set_option(),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
    ) -> None:
        """Train and test per variant (the paper's Table II) and write report.html and metrics.json.

        An existing report in --out is replaced only when it was made with the same settings and inputs, or with
        --overwrite; the new one is built beside it and swapped in whole (no old models or plots are left)."""
        names = [v.strip() for v in variants.split(",") if v.strip()] if variants is not None else None
        engine = ConfigArgs(config, {"--variants": ("train.variants", names), "--epochs": ("train.epochs", epochs),
                                     "--weights": ("train.weights", weights)},
                            sets=set_).engine(progress, note(err_console))
        report_summary(engine.report(data, out, real, overwrite=overwrite, fewshot=fewshot))
