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


def _value(run: dict, key: str) -> float:
    return run["synthetic"][key.removeprefix("synthetic_")] if key.startswith("synthetic_") else run["real"][key]


def _mine(results: dict, variant: str) -> list[dict]:
    return [r for r in results["runs"] if r["variant"] == variant]


def _hero(results: dict) -> str:
    v, s = max(results["variants"].items(), key=lambda kv: kv[1]["accuracy_mean"])
    n = results.get("real_images", len(results["real_paths"]))
    accs, base = [r["real"]["accuracy"] for r in _mine(results, v)], results["majority_baseline"]
    verdict = "above" if min(accs) > base else "below" if max(accs) < base else ""
    judged = {"above": "every run above", "below": "every run below"}.get(verdict, "runs on both sides of")
    return (
        f'<div class="hero"><div class="card"><div class="big {verdict}">{100 * s["accuracy_mean"]:.1f}%</div>'
        f'<div>sim-to-real accuracy <span class=sub>± {100 * s["accuracy_std"]:.1f} (std over runs)</span></div>'
        f'<div class="sub">{judged} the majority baseline</div>'
        f'<div class="sub">best variant <b>{escape(v)}</b>: mean of {s["n_runs"]} runs, each tested on {n} real '
        f'photographs</div></div><div class="card"><div class="mid">{_pm(s["f1_mean"], s["f1_std"])}</div>'
        f'<div>F1 (%, deformed = positive)</div><div class="sub">precision {_pm(s["precision_mean"], s["precision_std"])}'
        f' · recall {_pm(s["recall_mean"], s["recall_std"])}</div></div><div class="card"><div class="mid">'
        f'{100 * results["majority_baseline"]:.1f}%</div><div>majority-class baseline</div><div class="sub">accuracy '
        "of always answering the commoner label</div></div></div>"
    )


def _summary_table(results: dict, eces: dict[str, float]) -> str:
    head = "".join(f"<th>{label}</th>" for _, label in METRICS) + ("<th>ECE (pooled)</th>" if eces else "")
    rows = []
    for v, s in results["variants"].items():
        cells = "".join(f"<td>{_pm(s[f'{k}_mean'], s[f'{k}_std'])}</td>" for k, _ in METRICS)
        ece = f"<td>{eces[v]:.3f}</td>" if eces else ""
        rows.append(f"<tr><td><b>{escape(v)}</b></td><td>{s['n_runs']}</td>{cells}{ece}</tr>")
    return f'<table class="t2"><tr><th>Trained on</th><th>runs</th>{head}</tr>{"".join(rows)}</table>'


def _ensembles_table(results: dict) -> str:
    """Each draw's ensemble of its training seeds, mean ± std over the draws; empty without ensembles."""
    ens = results.get("ensembles") or {}
    if not ens:
        return ""
    rows = "".join(f"<tr><td><b>{escape(v)}</b></td><td>{e['n_draws']} x {e['members']}</td>"
                   + "".join(f"<td>{_pm(e[f'{k}_mean'], e[f'{k}_std'])}</td>" for k, _ in METRICS[:REAL]) + "</tr>"
                   for v, e in ens.items())
    head = "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL])
    return ("<h2>Ensembles of the training seeds</h2><p class=note>Percent. Each draw (data and background seed) "
            "averages the probabilities of its training seeds' models into one prediction; mean ± std over the "
            f'draws.</p><table class="t2"><tr><th>Trained on</th><th>draws x seeds</th>{head}</tr>{rows}</table>')


def _baseline_table(results: dict) -> str:
    """The paired differences to the baseline benchmark; empty without one."""
    base = results.get("baseline")
    if not base:
        return ""
    parts = (("runs", "run against run"), ("ensemble", "ensembles"), ("ensemble_vs_single", "ensembles against "
                                                                                          "single baseline runs"))
    rows = []
    for v, c in base["comparison"].items():
        for part, name in parts:
            cells = "".join(
                f"<td>{'<b>' if d['clears'] else ''}{100 * d['diff']:+.1f} ({100 * d['low']:+.1f} to "
                f"{100 * d['high']:+.1f}){'</b>' if d['clears'] else ''}</td>"
                for d in (c[part][k] for k, _ in METRICS[:REAL]))
            rows.append(f"<tr><td><b>{escape(v)}</b>, {name}</td><td>{c['pairs']}</td>{cells}</tr>")
    head = "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL])
    return (f"<h2>Difference to the baseline</h2><p class=note>Points, against {escape(str(base['results']))}, on the "
            "same photos: the mean over paired runs (same variant and seeds) and its 95 % interval from resampling "
            "the photos and the pairs; bold where the interval excludes zero.</p>"
            f'<table class="t2"><tr><th>Trained on</th><th>pairs</th>{head}</tr>{"".join(rows)}</table>')


def _bars(results: dict) -> str:
    series = {v: [(s[f"{k}_mean"], s[f"{k}_std"], [_value(r, k) for r in _mine(results, v)]) for k, _ in METRICS[:PLOTTED]]
              for v, s in results["variants"].items()}
    png = error_bars_png([label for _, label in METRICS[:PLOTTED]], series,
                         (results["majority_baseline"], "majority baseline (accuracy)"))
    return f"<div class=plots><img src='{data_uri(png, 'image/png')}' alt='mean and std per variant'></div>"


def _runs_table(results: dict, labels: list[int] | None) -> str:
    head = ("<tr><th>Variant</th><th>data seed</th><th>background seed</th><th>train seed</th>"
            + "".join(f"<th>{label}</th>" for _, label in METRICS[:REAL]) + "<th>TN · FP · FN · TP</th>"
            + "".join(f"<th>{label}</th>" for _, label in METRICS[REAL:]) + ("<th>ECE</th>" if labels else "") + "</tr>")
    rows = []
    for r in results["runs"]:
        seeds = "".join(f"<td>{'—' if r[k] is None else escape(str(r[k]))}</td>"
                        for k in ("data_seed", "composite_seed", "train_seed"))
        scores = [f"<td>{100 * _value(r, k):.1f}</td>" for k, _ in METRICS]
        (tn, fp), (fn, tp) = r["real"]["confusion"]
        ece = f"<td>{reliability(labels, r['real_predictions'])['ece']:.3f}</td>" if labels else ""
        rows.append(f"<tr title=\"{escape(str(r.get('model', '')))}\"><td>{escape(r['variant'])}</td>{seeds}"
                    f"{''.join(scores[:REAL])}<td>{' · '.join(escape(str(n)) for n in (tn, fp, fn, tp))}</td>"
                    f"{''.join(scores[REAL:])}{ece}</tr>")
    return f'<table class="t2 runs">{head}{"".join(rows)}</table>'


def _often_wrong(results: dict) -> str:
    """Per variant, every real photo that a run got wrong, most often wrong first."""
    blocks = "".join(f"<h3>{escape(v)}: {len(photos)} of {len(results['real_paths'])} photos wrong in a run</h3>"
                     + wrong_table(photos) for v, photos in often_wrong(results).items())
    return ("<h2>Photos most often wrong</h2><p class=note>Each real photo that at least one run judged wrong: in "
            "how many runs of its variant, and its mean P(deformed) over them (threshold "
            f"{results['settings']['train']['threshold']:g}); each file name links to the full-size photo. A photo "
            "wrong in every run is one the renders do not teach (or whose damage the photo does not show); one wrong in "
            f"some runs only depends on the draw.</p>{blocks}")


def _pooled(results: dict, labels: list[int]) -> dict[str, dict]:
    """Per variant: the reliability bins of every run's real predictions together."""
    out = {}
    for v in results["variants"]:
        mine = _mine(results, v)
        out[v] = reliability(labels * len(mine), [p for r in mine for p in r["real_predictions"]])
    return out


def _settings(results: dict) -> str:
    plan = results["plan"]
    rows = [("real folder", results.get("real_dir")), ("real photographs", len(results["real_paths"])),
            ("created", results.get("created")), ("total time", f"{results.get('seconds', 0):.0f} s"),
            ("adapted to", results.get("adapt") or "—")]
    rows += [(f"plan.{k}", ", ".join(map(str, val)) if isinstance(val, list) else val) for k, val in plan.items()]
    body = "".join(f"<tr><td>{escape(k)}</td><td>{escape(str(val))}</td></tr>" for k, val in rows)
    full = escape(json.dumps(results.get("settings", {}), indent=1, sort_keys=True))
    return (f'<h2>Settings</h2><table class="kv">{body}</table>'
            f"<details><summary class=note>every setting</summary><pre><code>{full}</code></pre></details>")


def render_benchmark_html(results: dict) -> str:
    """The benchmark page as a string."""
    labels = results.get("real_labels")
    pooled = _pooled(results, labels) if labels is not None else {}
    calibration = (
        "<h2>Calibration on the real photographs</h2><p class=note>Reliability diagrams of every run's predictions "
        "of a variant pooled: the predictions binned by P(deformed); each blue bar is the share of deformed photos "
        "(number of predictions above it), hatched red its gap to the bin's mean prediction; a calibrated model "
        "follows the dashed diagonal. ECE: the prediction-weighted mean gap.</p>"
        f"<div class=plots><img src='{data_uri(reliability_png(pooled), 'image/png')}' alt='reliability diagrams'>"
        "</div>" if pooled else "<p class=note>No real labels in the results: no reliability diagram.</p>"
    )
    parts = [
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>",
        "<meta name=viewport content='width=device-width,initial-scale=1'>",
        f"<title>deformsim sim-to-real benchmark</title><style>{CSS}{EXTRA_CSS}</style></head><body><main>",
        "<h1>Sim-to-real benchmark</h1>",
        f"<div class=sub>{escape(str(results.get('real_dir', '')))} · {escape(str(results.get('created', '')))}</div>",
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
        f"<h2>Every run ({len(results['runs'])})</h2><p class=note>Percent; the confusion matrix counts real photos "
        "(true intact: TN, FP; true deformed: FN, TP).</p>",
        _runs_table(results, labels),
        _often_wrong(results) if labels is not None else "",
        calibration,
        _settings(results),
        "</main></body></html>",
    ]
    return "\n".join(parts)


def write_benchmark_report(results: dict, out_dir: Path) -> Path:
    """Write ``out_dir/report.html`` from the benchmark's results; return its path."""
    path = Path(out_dir) / "report.html"
    write_text(path, render_benchmark_html(results))
    return path
