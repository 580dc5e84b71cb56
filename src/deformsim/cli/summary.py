"""The end-of-run summary on stdout: real-photo (else held-out) metrics with their 95 % intervals, the majority
baseline of the test set, and where the report is."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from deformsim.cli.common import console

if TYPE_CHECKING:
    from deformsim.evaluate.adaptation_file import AdaptBenchFile
    from deformsim.evaluate.fewshot_file import FewshotFile
    from deformsim.evaluate.metrics_file import Scores
    from deformsim.evaluate.results import Difference, ResultsFile, Spreads

WIDE = 200  # columns of a summary printed into a file or pipe, so that no cell wraps
NAMED_WRONG = 5  # photos named per variant after a benchmark's table; its report lists them all


def _share(value: float | None, interval: list[float] | None = None) -> str:
    if value is None:
        return "-"
    text = f"{100 * value:.1f}%"
    return f"{text} ({100 * interval[0]:.1f}-{100 * interval[1]:.1f})" if interval else text


def metric_cell(m: Scores, key: str) -> str:
    """Metric ``key`` of ``m`` as a percentage with its 95 % interval, "-" when undefined."""
    value = m.value(key)
    return "-" if value is None else _share(value, m.interval_of(key))


def print_table(table: Table, report: Path | None = None, notes: tuple[str, ...] = ()) -> None:
    """Print ``table`` on stdout (unwrapped in a file or pipe), then the lines of rich markup ``notes``, then where
    the report is."""
    (console if console.is_terminal else Console(width=WIDE)).print(table)
    for line in notes:
        console.print(line, highlight=False, soft_wrap=True)
    if report is not None:
        console.print(f"[bold]report:[/] {report}", highlight=False, soft_wrap=True)


def report_summary(report: Path) -> None:
    """Print the summary of the report at ``report`` (its report.html; metrics.json beside it)."""
    from deformsim.evaluate.metrics_file import read_metrics

    metrics = read_metrics(report.parent / "metrics.json")
    table = Table(title="Results (95 % intervals)", header_style="bold")
    for col in ("trained on", "tested on", "images", "accuracy", "F1", "precision", "recall", "majority class"):
        table.add_column(col, justify="left" if col in ("trained on", "tested on") else "right")
    for variant, entry in metrics.variants.items():
        for part, name in (("real", "real photos"), ("split", "held-out renders")):
            result = entry.ran(part)
            if result is None:
                continue
            m, test = result.metrics, result.test
            share = test.n_deformed / test.n if test.n else None
            table.add_row(variant, name, str(m.n), *(metric_cell(m, k) for k in ("accuracy", "f1", "precision", "recall")),
                          _share(None if share is None else max(share, 1 - share)))
    print_table(table, report)


def _spreads(row: Spreads, keys: tuple[str, ...]) -> list[str]:
    """``row``'s mean ± std of each key, in percent."""
    return [f"{100 * mean:.1f} ± {100 * std:.1f}%" for mean, std in map(row.spread, keys)]


def _often_wrong(results: ResultsFile) -> tuple[str, ...]:
    """Per variant with a wrong run: the photos its runs most often got wrong, by class folder and file name."""
    from deformsim.evaluate.paired import often_wrong

    lines = []
    for variant, photos in often_wrong(results).items():
        if photos:
            named = ", ".join(f"{p['name']} ({p['wrong']} of {p['runs']})" for p in photos[:NAMED_WRONG])
            more = f" and {len(photos) - NAMED_WRONG} more" if len(photos) > NAMED_WRONG else ""
            lines.append(f"[bold]most often wrong, {escape(variant)}:[/] {escape(named + more)}")
    return tuple(lines)


def sim2real_summary(results: ResultsFile, report: Path) -> None:
    """Print the sim-to-real benchmark's ``results`` (mean ± std over its runs), the photos most often wrong and
    where its report is."""
    from deformsim.evaluate.paired import METRICS

    table = Table(title=f"Real-photo results over {len(results.runs)} runs (mean ± std)", header_style="bold")
    for col in ("trained on", "runs", "accuracy", "F1", "precision", "recall", "AUC", "synthetic accuracy",
                "majority class"):
        table.add_column(col, justify="left" if col == "trained on" else "right")
    for variant, r in results.variants.items():
        cells = _spreads(r, (*METRICS, "synthetic_accuracy"))
        table.add_row(variant, str(r.n_runs), *cells, _share(results.majority_baseline))
        e = (results.ensembles or {}).get(variant)
        if e:
            cells = _spreads(e, METRICS)
            table.add_row(f"{variant}, ensemble of {e.members} seeds", str(e.n_draws), *cells, "", "")
    from deformsim.evaluate.experiments import low_synthetic_runs

    warnings = tuple(f"[bold yellow]warning:[/] {escape(line)}" for line in low_synthetic_runs(results))
    print_table(table, report, warnings + _often_wrong(results))
    if results.baseline is not None:
        baseline_summary(results)


def _difference(d: Difference) -> str:
    text = f"{100 * d.diff:+.1f} ({100 * d.low:+.1f} to {100 * d.high:+.1f})"
    return f"[bold]{text}[/]" if d.clears else text


def baseline_summary(results: ResultsFile) -> None:
    """Print the paired differences of ``results`` to its baseline: per variant (and its ensemble), each metric's
    mean difference in points with its 95 % interval, bold where the interval excludes zero."""
    from deformsim.evaluate.paired import METRICS

    table = Table(title=f"Difference to {results.baseline.results} (points, 95 % interval over photos and seeds)",
                  header_style="bold")
    for col in ("trained on", "pairs", "accuracy", "F1", "precision", "recall", "AUC", "verdict"):
        table.add_column(col, justify="left" if col in ("trained on", "verdict") else "right")
    for variant, c in results.baseline.comparison.items():
        for part, name in (("runs", variant), ("ensemble", f"{variant}, ensembles"),
                           ("ensemble_vs_single", f"{variant}, ensembles vs single baseline runs")):
            d = getattr(c, part)
            verdict = ("beats the baseline" if d["accuracy"].low > 0 else "below the baseline"
                       if d["accuracy"].high < 0 else "within the noise")
            table.add_row(name, str(c.pairs), *(_difference(d[k]) for k in METRICS),
                          f"accuracy {verdict}")
    print_table(table)


def fewshot_summary(results: FewshotFile, plot: Path) -> None:
    """Print the few-shot benchmark's ``results`` (per k and curve: mean and 95 % interval) and where its plot is."""
    from deformsim.evaluate.fewshot import CURVES, TITLES

    sample = ", a biased sample: each class from another lighting" if results.biased else ""
    table = Table(title=f"Real-photo results after adapting on k photos per class{sample} (mean, 95 % interval)",
                  header_style="bold")
    for col in ("k per class", "model", "runs", "accuracy", "F1", "interval over", "majority class"):
        table.add_column(col, justify="left" if col == "model" else "right")
    rows = {(r.k, curve): r for curve, curve_rows in results.curves.items() for r in curve_rows}
    for k, curve in sorted(rows, key=lambda key: (key[0], CURVES.index(key[1]))):
        r = rows[k, curve]
        table.add_row(str(k), TITLES[curve], str(r.runs), _share(r.accuracy, r.accuracy_interval),
                      _share(r.f1, r.f1_interval), r.interval, _share(r.majority))
    print_table(table, None)
    console.print(f"[bold]plot:[/] {plot}", highlight=False, soft_wrap=True)


def adaptation_summary(results: AdaptBenchFile) -> None:
    """Print the adaptation benchmark's rows: mean ± std over the models, and the paired difference in accuracy to
    the unadapted model."""
    table = Table(title=f"{len(results.models)} model(s) adapted to {results.photos} unlabelled photos "
                  "(labels read only to score)", header_style="bold")
    for col in ("model", "accuracy", "F1", "AUC", "accuracy vs unadapted (95 % interval)", "estimated deformed"):
        table.add_column(col, justify="left" if col == "model" else "right")

    def spread(row, key):
        value = getattr(row, key)
        return "-" if value is None else f"{value:.3f} ± {getattr(row, f'{key}_std'):.3f}"

    for name, row in results.rows.items():
        paired = (row.paired or {}).get("accuracy")
        diff = "" if paired is None else (f"{100 * paired.diff:+.1f} ({100 * paired.low:+.1f} to "
                                          f"{100 * paired.high:+.1f})")
        prior = ", ".join(f"{v:.0%}" for priors in row.prior or [] for v in priors)
        table.add_row(escape(name), spread(row, "accuracy"), spread(row, "f1"), spread(row, "auc"), diff, prior)
    print_table(table, None)
    console.print(f"true share deformed {results.true_share:.0%}", highlight=False)
    if results.kshot:
        sample = "a biased sample: each class from another lighting" if results.biased else "drawn at random"
        kshot = Table(title=f"k labelled photos per class ({sample}), scored on the rest ({results.draws} draws per "
                      "model)",
                      header_style="bold")
        for col in ("k", "model", "runs", "accuracy", "vs unadapted (95 % interval)"):
            kshot.add_column(col, justify="left" if col == "model" else "right")
        for r in results.kshot:
            paired = "" if r.paired is None else (f"{100 * r.paired:+.1f} ({100 * r.paired_interval[0]:+.1f} "
                                                  f"to {100 * r.paired_interval[1]:+.1f})")
            kshot.add_row(str(r.k), escape(r.curve), str(r.runs), f"{r.accuracy:.3f} ± {r.accuracy_std:.3f}", paired)
        print_table(kshot, None)
    if results.unlabelled:
        curve = Table(title=f"n unlabelled photos drawn at random ({results.draws} draws per model)",
                      header_style="bold")
        for col in ("n", "model", "runs", "accuracy", "unadapted, same photos", "vs unadapted (95 % interval)"):
            curve.add_column(col, justify="left" if col == "model" else "right")
        for r in results.unlabelled:
            curve.add_row(str(r.n), escape(r.curve), str(r.runs), f"{r.accuracy:.3f} ± {r.accuracy_std:.3f}",
                          f"{r.unadapted:.3f}", f"{100 * r.paired:+.1f} ({100 * r.paired_interval[0]:+.1f} to "
                          f"{100 * r.paired_interval[1]:+.1f})")
        print_table(curve, None)
