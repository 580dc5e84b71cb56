"""Render the sim-to-real benchmark's ``results.json`` (:func:`deformsim.evaluate.benchmark.run_benchmark`) as one
self-contained HTML page: mean ± std per variant, every run, and the calibration of the pooled real predictions.
"""

from __future__ import annotations

import json
from html import escape
from pathlib import Path

from deformsim.atomic import write_text
from deformsim.evaluate.calibration import reliability
from deformsim.evaluate.experiments import low_synthetic_runs
from deformsim.evaluate.paired import often_wrong
from deformsim.evaluate.results import ResultsFile
from deformsim.report.figures import data_uri, error_bars_png, reliability_png
from deformsim.report.html import CSS
from deformsim.report.predictions import wrong_table

METRICS = (("accuracy", "real accuracy"), ("f1", "real F1"), ("precision", "real precision"),
           ("recall", "real recall"), ("auc", "real AUC"), ("synthetic_accuracy", "synthetic accuracy"),
           ("synthetic_f1", "synthetic F1"))
REAL = len(METRICS) - 2  # the real-photo metrics come first
PLOTTED = len(METRICS) - 1  # the bar chart leaves out synthetic F1
EXTRA_CSS = ".t2 td{white-space:nowrap}.runs{font-size:13px}"


def _pm(mean: float, std: float) -> str:
    return f"{100 * mean:.1f} ± {100 * std:.1f}"


def _hero(results: ResultsFile) -> str:
    v, s = max(results.variants.items(), key=lambda kv: kv[1].accuracy_mean)
    n = results.real_images
    accs, base = [r.real.accuracy for r in results.of(v)], results.majority_baseline
    verdict = "above" if min(accs) > base else "below" if max(accs) < base else ""
    judged = {"above": "every run above", "below": "every run below"}.get(verdict, "runs on both sides of")
    return (
        f'<div class="hero"><div class="card"><div class="big {verdict}">{100 * s.accuracy_mean:.1f}%</div>'
        f'<div>sim-to-real accuracy <span class=sub>± {100 * s.accuracy_std:.1f} (std over runs)</span></div>'
        f'<div class="sub">{judged} the majority baseline</div>'
        f'<div class="sub">best variant <b>{escape(v)}</b>: mean of {s.n_runs} runs, each tested on {n} real '
        f'photographs</div></div><div class="card"><div class="mid">{_pm(*s.spread("f1"))}</div>'
        f'<div>F1 (%, deformed = positive)</div><div class="sub">precision {_pm(*s.spread("precision"))}'
        f' · recall {_pm(*s.spread("recall"))}</div></div><div class="card"><div class="mid">'
        f'{100 * base:.1f}%</div><div>majority-class baseline</div><div class="sub">accuracy '
        "of always answering the commoner label</div></div></div>"
    )


def _summary_table(results: ResultsFile, eces: dict[str, float]) -> str:
    head = "".join(f"<th>{label}</th>" for _, label in METRICS) + ("<th>ECE (pooled)</th>" if eces else "")
    rows = []
    for v, s in results.variants.items():
        cells = "".join(f"<td>{_pm(*s.spread(k))}</td>" for k, _ in METRICS)
        ece = f"<td>{eces[v]:.3f}</td>" if eces else ""
        rows.append(f"<tr><td><b>{escape(v)}</b></td><td>{s.n_runs}</td>{cells}{ece}</tr>")
    return f'<table class="t2"><tr><th>Trained on</th><th>runs</th>{head}</tr>{"".join(rows)}</table>'


def _ensembles_table(results: ResultsFile) -> str:
    """Each draw's ensemble of its training seeds, mean ± std over the draws; empty without ensembles."""
    if not results.ensembles:
        return ""
    rows = "".join(f"<tr><td><b>{escape(v)}</b></td><td>{e.n_draws} x {e.members}</td>"
                   + "".join(f"<td>{_pm(*e.spread(k))}</td>" for k, _ in METRICS[:REAL]) + "</tr>"
                   for v, e in results.ensembles.items())
    head = "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL])
    return ("<h2>Ensembles of the training seeds</h2><p class=note>Percent. Each draw (data and background seed) "
            "averages the probabilities of its training seeds' models into one prediction; mean ± std over the "
            f'draws.</p><table class="t2"><tr><th>Trained on</th><th>draws x seeds</th>{head}</tr>{rows}</table>')


def _baseline_table(results: ResultsFile) -> str:
    """The paired differences to the baseline benchmark; empty without one."""
    base = results.baseline
    if base is None:
        return ""
    parts = (("runs", "run against run"), ("ensemble", "ensembles"), ("ensemble_vs_single", "ensembles against "
                                                                                          "single baseline runs"))
    rows = []
    for v, c in base.comparison.items():
        for part, name in parts:
            cells = "".join(
                f"<td>{'<b>' if d.clears else ''}{100 * d.diff:+.1f} ({100 * d.low:+.1f} to "
                f"{100 * d.high:+.1f}){'</b>' if d.clears else ''}</td>"
                for d in (getattr(c, part)[k] for k, _ in METRICS[:REAL]))
            rows.append(f"<tr><td><b>{escape(v)}</b>, {name}</td><td>{c.pairs}</td>{cells}</tr>")
    head = "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL])
    return (f"<h2>Difference to the baseline</h2><p class=note>Points, against {escape(base.results)}, on the "
            "same photos: the mean over paired runs (same variant and seeds) and its 95 % interval from resampling "
            "the photos and the pairs; bold where the interval excludes zero.</p>"
            f'<table class="t2"><tr><th>Trained on</th><th>pairs</th>{head}</tr>{"".join(rows)}</table>')


def _bars(results: ResultsFile) -> str:
    series = {v: [(*s.spread(k), [r.value(k) for r in results.of(v)]) for k, _ in METRICS[:PLOTTED]]
              for v, s in results.variants.items()}
    png = error_bars_png([label for _, label in METRICS[:PLOTTED]], series,
                         (results.majority_baseline, "majority baseline (accuracy)"))
    return f"<div class=plots><img src='{data_uri(png, 'image/png')}' alt='mean and std per variant'></div>"


def _runs_table(results: ResultsFile) -> str:
    labels = results.real_labels
    head = ("<tr><th>Variant</th><th>data seed</th><th>background seed</th><th>train seed</th>"
            + "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL]) + "<th>TN · FP · FN · TP</th>"
            + "".join(f"<th>{label}</th>" for _, label in METRICS[REAL:]) + ("<th>ECE</th>" if labels else "") + "</tr>")
    rows = []
    for r in results.runs:
        seeds = "".join(f"<td>{'—' if seed is None else escape(str(seed))}</td>"
                        for seed in (r.data_seed, r.composite_seed, r.train_seed))
        scores = [f"<td>{100 * r.value(k):.1f}</td>" for k, _ in METRICS]
        (tn, fp), (fn, tp) = r.real.confusion
        ece = f"<td>{reliability(labels, r.real_predictions)['ece']:.3f}</td>" if labels else ""
        rows.append(f"<tr title=\"{escape(str(r.model))}\"><td>{escape(r.variant)}</td>{seeds}"
                    f"{''.join(scores[:REAL])}<td>{' · '.join(escape(str(n)) for n in (tn, fp, fn, tp))}</td>"
                    f"{''.join(scores[REAL:])}{ece}</tr>")
    return f'<table class="t2 runs">{head}{"".join(rows)}</table>'


def _often_wrong(results: ResultsFile) -> str:
    """Per variant, every real photo that a run got wrong, most often wrong first."""
    blocks = "".join(f"<h3>{escape(v)}: {len(photos)} of {len(results.real_paths)} photos wrong in a run</h3>"
                     + wrong_table(photos) for v, photos in often_wrong(results).items())
    return ("<h2>Photos most often wrong</h2><p class=note>Each real photo that at least one run judged wrong: in "
            "how many runs of its variant, and its mean P(deformed) over them (threshold "
            f"{results.threshold:g}); each file name links to the full-size photo. A photo "
            "wrong in every run is one the renders do not teach (or whose damage the photo does not show); one wrong in "
            f"some runs only depends on the draw.</p>{blocks}")


def _pooled(results: ResultsFile) -> dict[str, dict]:
    """Per variant: the reliability bins of every run's real predictions together."""
    out = {}
    for v in results.variants:
        mine = results.of(v)
        out[v] = reliability(results.real_labels * len(mine), [p for r in mine for p in r.real_predictions])
    return out


def _settings(results: ResultsFile) -> str:
    plan = results.plan.model_dump(exclude_unset=True, by_alias=True)
    rows = [("real folder", results.real_dir), ("real photographs", len(results.real_paths)),
            ("created", results.created), ("total time", f"{results.seconds:.0f} s"),
            ("adapted to", results.adapt or "—")]
    rows += [(f"plan.{k}", ", ".join(map(str, val)) if isinstance(val, list) else val) for k, val in plan.items()]
    body = "".join(f"<tr><td>{escape(k)}</td><td>{escape(str(val))}</td></tr>" for k, val in rows)
    full = escape(json.dumps(results.config(), indent=1, sort_keys=True))
    return (f'<h2>Settings</h2><table class="kv">{body}</table>'
            f"<details><summary class=note>every setting</summary><pre><code>{full}</code></pre></details>")


def render_benchmark_html(results: ResultsFile) -> str:
    """The benchmark page as a string."""
    pooled = _pooled(results)
    calibration = (
        "<h2>Calibration on the real photographs</h2><p class=note>Reliability diagrams of every run's predictions "
        "of a variant pooled: the predictions binned by P(deformed); each blue bar is the share of deformed photos "
        "(number of predictions above it), hatched red its gap to the bin's mean prediction; a calibrated model "
        "follows the dashed diagonal. ECE: the prediction-weighted mean gap.</p>"
        f"<div class=plots><img src='{data_uri(reliability_png(pooled), 'image/png')}' alt='reliability diagrams'>"
        "</div>"
    )
    parts = [
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>",
        "<meta name=viewport content='width=device-width,initial-scale=1'>",
        f"<title>deformsim sim-to-real benchmark</title><style>{CSS}{EXTRA_CSS}</style></head><body><main>",
        "<h1>Sim-to-real benchmark</h1>",
        f"<div class=sub>{escape(results.real_dir)} · {escape(results.created or '')}</div>",
        "".join(f"<div class=warn><b>Warning:</b> {escape(line)}</div>" for line in low_synthetic_runs(results)),
        _hero(results),
        "<h2>Results by training variant</h2>",
        "<p class=note>Percent, mean ± sample standard deviation over runs. Each run trains on synthetic images only "
        "and is tested on the real photographs and on the synthetic scenes held out of its training; runs differ in "
        "the dataset, background and training seeds. Deformed is the positive class.</p>",
        _summary_table(results, {v: d["ece"] for v, d in pooled.items()}),
        "<p class=note>Bars: means; whiskers: ± one standard deviation; dots: the runs.</p>",
        _bars(results),
        _ensembles_table(results),
        _baseline_table(results),
        f"<h2>Every run ({len(results.runs)})</h2><p class=note>Percent; the confusion matrix counts real photos "
        "(true intact: TN, FP; true deformed: FN, TP).</p>",
        _runs_table(results),
        _often_wrong(results),
        calibration,
        _settings(results),
        "</main></body></html>",
    ]
    return "\n".join(parts)


def write_benchmark_report(results: ResultsFile, out_dir: Path) -> Path:
    """Write ``out_dir/report.html`` from the benchmark's results; return its path."""
    path = Path(out_dir) / "report.html"
    write_text(path, render_benchmark_html(results))
    return path
