"""Render ``metrics.json`` (from :func:`deformsim.evaluate.experiments.run_experiments`) as one HTML page.

The page is self-contained: CSS inline, every image a base64 ``data:`` URI, no external resource. Plot files
named in ``metrics.plots`` are read relative to the report folder.
"""

from __future__ import annotations

from html import escape
from pathlib import Path

from deformsim.atomic import write_text
from deformsim.dataset.images import CLASSES
from deformsim.evaluate.calibration import reliability
from deformsim.evaluate.experiments import low_synthetic
from deformsim.evaluate.metrics_file import Experiment, MetricsFile, Scores, Variant
from deformsim.learn.train_file import Epoch
from deformsim.report.dense_html import dense_section
from deformsim.report.fewshot_html import fewshot_section
from deformsim.report.figures import curves_png, data_uri, png_file_uri, reliability_png
from deformsim.report.headline import headline
from deformsim.report.predictions import predictions_section, thumb
from deformsim.report.settings import settings_section

REAL_SHOWN = 6  # real photos shown per class beside the synthetic samples

KEYS = (("accuracy", "Acc"), ("f1", "F1"), ("precision", "Prec."), ("recall", "Recall"))
PARTS = (("split", "Synthetic test (held out)"), ("real", "Real test (sim-to-real)"))
WITH_INTERVAL = ("accuracy", "f1")

CSS = """
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#1d2433;background:#f4f6f9;margin:0}
main{max-width:1080px;margin:0 auto;padding:28px 28px 60px}
h1{font-size:24px;margin:0 0 4px}
h2{font-size:18px;margin:34px 0 10px;border-bottom:2px solid #dfe4ec;padding-bottom:4px}
.sub{color:#5b6475;font-size:13px}
.note{color:#5b6475;font-size:13px;margin:6px 0}
.card{background:#fff;border-radius:10px;box-shadow:0 1px 3px #0002;padding:16px 20px}
.hero{display:flex;gap:18px;flex-wrap:wrap;margin-top:18px}
.hero .card{flex:1;min-width:220px}
.big{font-size:56px;font-weight:700;line-height:1.05;color:#5b6475}
.big.above{color:#0b6e4f}
.big.below{color:#b3261e}
.ci{display:block;font-size:11px;font-weight:400;color:#5b6475}
.scroll{overflow-x:auto;max-width:100%}
.sub,.note,.kv td+td,.wrong td.name{overflow-wrap:anywhere}
.mid{font-size:30px;font-weight:600;color:#2c4a7a}
table.t2{border-collapse:collapse;width:100%;background:#fff;font-variant-numeric:tabular-nums}
.t2 th,.t2 td{padding:7px 10px;text-align:center;border-bottom:1px solid #e6e9ef}
.t2 th{background:#eef1f6;font-weight:600}
.t2 .v{text-align:left}
.hint{display:none;color:#5b6475;font-size:12px;margin:4px 0 0}
.t2 .grp{border-left:2px solid #c9d1de}
.best{font-weight:700}
.cms{display:flex;flex-wrap:wrap;gap:14px}
.cm{background:#fff;border-radius:8px;padding:10px 12px;box-shadow:0 1px 2px #0002}
.cm table{border-collapse:collapse;font-size:13px}
.cm td{width:62px;height:40px;text-align:center;font-weight:600}
.cm th{font-weight:500;font-size:11px;color:#5b6475;padding:2px 6px}
.cm .title{font-size:13px;font-weight:600;margin-bottom:6px}
.plots{display:flex;flex-wrap:wrap;gap:14px}
.plots img{background:#fff;border-radius:8px;box-shadow:0 1px 2px #0002;width:100%;height:auto}
.plots.two img{width:calc(50% - 7px)}
.grid{display:flex;flex-wrap:wrap;gap:10px}
.thumb{background:#fff;border-radius:8px;padding:6px;width:124px;box-shadow:0 1px 2px #0002;font-size:12px;
  text-align:center;border-top:4px solid #ccc}
.thumb img{width:120px;height:120px;object-fit:contain;background:#222;border-radius:4px;display:block}
.thumb.ok{border-top-color:#2e9e5b}
.thumb.bad{border-top-color:#d0342c}
.thumb.cam{width:184px}
.thumb.cam img,.thumb.cam .missing{width:180px;height:180px}
.missing{width:120px;height:120px;background:#ddd;display:flex;align-items:center;justify-content:center;color:#777}
.kv{border-collapse:collapse;font-size:13px}
.kv td{padding:3px 14px 3px 0;border-bottom:1px solid #e6e9ef;vertical-align:top}
.kv td:first-child{color:#5b6475;min-width:8em;overflow-wrap:normal;hyphens:none}
code{font-size:12px}
.warn{background:#fdecea;border-left:5px solid #b3261e;border-radius:6px;padding:10px 14px;margin:16px 0 0}
pre.yaml{background:#fff;border-radius:8px;padding:10px 14px;font-size:12px;overflow-x:auto}
table.wrong{border-collapse:collapse;background:#fff;font-size:13px;width:100%}
.wrong td,.wrong th{padding:4px 8px;border-bottom:1px solid #e6e9ef;text-align:left;vertical-align:middle}
.wrong img{width:64px;height:64px;object-fit:contain;background:#222;border-radius:4px;display:block}
@media (max-width:640px){main{padding:16px 12px 40px}.big{font-size:44px}.plots.two img{width:100%}
  .t2 th,.t2 td{padding:5px 6px;font-size:13px}.hint{display:block}
  .t2 .v{position:sticky;left:0;z-index:1;background:#fff;box-shadow:2px 0 3px #0001}.t2 th.v{background:#eef1f6}
  .hero .card{min-width:0;flex-basis:100%}.thumb.cam{width:calc(50% - 17px)}
  .thumb.cam img,.thumb.cam .missing{width:100%;height:auto;aspect-ratio:1}}
"""


def _pct(x: float | None) -> str:
    return "—" if x is None else f"{100 * x:.1f}%"


def _span(iv: list[float] | None) -> str:
    return "" if iv is None else f"{100 * iv[0]:.1f}–{100 * iv[1]:.1f}%"


def _verdict(m: Scores) -> str:
    """"above" when the accuracy's 95 % interval lies above the majority baseline, "below" when under it, else ""."""
    iv = m.interval_of("accuracy")
    if iv is None:
        return ""
    base = m.baseline()
    return "above" if iv[0] > base else "below" if iv[1] < base else ""


def _shade(x: float) -> str:
    """Background for a score: pale red at 0.5 and below, pale green at 1."""
    t = max(0.0, min(1.0, (x - 0.5) / 0.5))
    return f"hsl({int(4 + 126 * t)},60%,{92 - 8 * t:.0f}%)"


def _hero(metrics: MetricsFile) -> str:
    head = headline(metrics)
    if head is None:
        return '<div class="card">No experiment ran (see the notes in the table).</div>'
    v, part, r = head
    m = r.metrics
    what = ("sim-to-real accuracy" if part == "real" else "accuracy on held-out synthetic images"
            + " <em>(no real test set given)</em>")
    baseline, verdict = m.baseline(), _verdict(m)
    iv = m.interval_of("accuracy")
    judged = {"above": "above the majority baseline", "below": "below the majority baseline"}.get(
        verdict, f"not distinguishable from the majority baseline ({_pct(baseline)})")
    ci = f"95 % interval {_span(iv)} (Wilson): {judged}" if iv else ""
    cards = [
        f'<div class="card"><div class="big {verdict}">{_pct(m.accuracy)}</div><div>{what}</div>'
        f'<div class="sub">{ci}</div>'
        f'<div class="sub">model trained on {escape(str(r.train.n))} synthetic <b>{escape(v)}</b> images, '
        f'tested on {escape(str(m.n))} {"real photographs" if part == "real" else "held-out images"}</div></div>'
    ]
    f1_iv = m.interval_of("f1")
    shares = " · ".join(f'{k} {_pct(m.value(k))}' + (f" ({_span(m.interval_of(k))})" if m.interval_of(k) else "")
                        for k in ("precision", "recall"))
    cards.append(
        f'<div class="card"><div class="mid">{_pct(m.value("f1"))}</div><div>F1 (deformed = positive)</div>'
        + (f'<div class="sub">95 % interval {_span(f1_iv)} (Wilson)</div>' if f1_iv else "")
        + f'<div class="sub">{shares} · threshold {m.threshold:g}</div></div>'
    )
    split = metrics.variants[v].ran("split") if part == "real" else None
    extra = f"<br>held-out synthetic accuracy {_pct(split.metrics.accuracy)}" if split else ""
    cards.append(
        f'<div class="card"><div class="mid">{_pct(baseline)}</div><div>majority-class baseline</div>'
        f'<div class="sub">accuracy of always answering the commoner label{extra}</div></div>'
    )
    return f'<div class="hero">{"".join(cards)}</div>'


def _clear_best(metrics: MetricsFile) -> set[tuple[str, str, str]]:
    """(variant, part, key) of each value whose 95 % interval lies wholly above every other variant's."""
    out = set()
    for part, _ in PARTS:
        ran = [(v, r.metrics) for v, p, r in metrics.results() if p == part]
        for k in WITH_INTERVAL:
            ivs = {v: m.interval_of(k) for v, m in ran}
            for v, iv in ivs.items():
                others = [o for w, o in ivs.items() if w != v]
                if iv is not None and others and all(o is not None and iv[0] > o[1] for o in others):
                    out.add((v, part, k))
    return out


def _table2(metrics: MetricsFile) -> str:
    best = _clear_best(metrics)
    real = any(part == "real" for _, part, _ in metrics.results())
    parts = PARTS[::-1] if real else PARTS  # the real-photo test, the headline, first: on a phone it is on screen
    head = "".join(f'<th colspan="4" class="grp">{title}</th>' for _, title in parts)
    sub = "".join(
        f'<th{" class=grp" if i == 0 else ""}>{label}</th>' for _ in parts for i, (_, label) in enumerate(KEYS)
    )
    rows = []
    for v, e in metrics.variants.items():
        cells = []
        for part, _ in parts:
            r = e.ran(part)
            if r is None:
                why = "no real folder given" if getattr(e, part) is None else getattr(e, part).skipped
                cells.append(f'<td colspan="4" class="grp sub" title="{escape(why)}">— {escape(why)}</td>')
                continue
            for i, (k, _) in enumerate(KEYS):
                x = r.metrics.value(k)
                cls = " ".join(c for c in ("grp" if i == 0 else "", "best" if (v, part, k) in best else "") if c)
                shade = f' style="background:{_shade(x)}"' if x is not None else ""
                ci = _span(r.metrics.interval_of(k))
                cells.append(f'<td class="{cls}"{shade}>{_pct(x)}{f"<span class=ci>{ci}</span>" if ci else ""}</td>')
        rows.append(f"<tr><td class=v><b>{escape(v)}</b><div class=sub>{escape(str(e.n_images))} images</div></td>"
                    f"{''.join(cells)}</tr>")
    hint = "the held-out synthetic columns" if real else "more columns"
    return (f'<div class=scroll><table class="t2"><tr><th rowspan="2" class=v>Training variant</th>{head}</tr>'
            f'<tr>{sub}</tr>{"".join(rows)}</table></div><p class=hint>Swipe the table sideways for {hint} →</p>'
            "<p class=note>Under each value: its 95 % interval (Wilson's: accuracy over the images, precision over "
            "those predicted deformed, recall over the deformed ones, F1 as TP out of TP + (FP + FN) / 2). Bold: a "
            "value whose interval lies wholly above every other variant's; none is bold where the intervals overlap. "
            "— : undefined (precision with no image predicted deformed).</p>")


def _confusion(title: str, cm: list[list[int]]) -> str:
    body = []
    for i, row in enumerate(cm):
        total = sum(row) or 1
        tds = []
        for j, n in enumerate(row):
            frac = n / total
            hue = 145 if i == j else 4
            tds.append(f'<td style="background:hsl({hue},55%,{96 - 40 * frac:.0f}%)" '
                       f'title="{escape(str(n))} of {escape(str(sum(row)))} true {CLASSES[i]}">{escape(str(n))}</td>')
        body.append(f"<tr><th>true {CLASSES[i]}</th>{''.join(tds)}</tr>")
    pred = "".join(f"<th>pred. {c}</th>" for c in CLASSES)
    return (f'<div class="cm"><div class="title">{escape(title)}</div><table>'
            f"<tr><th></th>{pred}</tr>{''.join(body)}</table></div>")


def _real_results(metrics: MetricsFile) -> list[tuple[str, Experiment]]:
    return [(v, r) for v, part, r in metrics.results() if part == "real"]


def _calibration(metrics: MetricsFile) -> str:
    diagrams = {v: reliability([p.y for p in r.predictions], [p.prob for p in r.predictions])
                for v, r in _real_results(metrics)}
    if not diagrams:
        return ""
    eces = " · ".join(f"<b>{escape(v)}</b> {d['ece']:.3f}" for v, d in diagrams.items())
    return ("<h2>Calibration on the real photographs</h2><p class=note>Reliability diagrams of each variant's "
            "real-test model: the photos binned by predicted P(deformed); each blue bar is the share of its photos "
            "that are deformed (number of photos above it), hatched red its gap to the bin's mean prediction. A "
            "calibrated model follows the dashed diagonal. Expected calibration error (ECE, the photo-weighted mean "
            f"gap): {eces}.</p><div class='plots two'>"
            + "".join(f"<img src='{data_uri(reliability_png({v: d}), 'image/png')}' alt='reliability diagram of "
                      f"{escape(v)}'>" for v, d in diagrams.items()) + "</div>")


def _gradcams(metrics: MetricsFile, out_dir: Path) -> str:
    blocks = []
    for v, r in _real_results(metrics):
        if not r.gradcam:
            continue
        thr = r.metrics.threshold
        cells = [thumb(out_dir / g.image, f'{CLASSES[g.y]} · P(deformed) {g.prob:.2f}'
                        f'<div class=sub>{escape(Path(g.path).name)}</div>',
                        "cam " + ("bad" if (g.prob >= thr) != bool(g.y) else "ok"), 180, g.path)
                 for g in r.gradcam]
        blocks.append(f"<h3>{escape(v)}</h3><p class=note>{len(cells)} of the {len(r.predictions)} photos, in "
                      f"review order.</p><div class=grid>{''.join(cells)}</div>")
    if not blocks:
        return ""
    return ("<h2>Where the models look (Grad-CAM)</h2><p class=note>For each variant's real-test model, the "
            "regions of the photo whose features raise P(deformed) most (red and yellow; scaled per photo). A model "
            "that transfers looks at the dent, not at the background. Misclassified photos first (red top border), "
            "then the others, least confident first; captions give the true label.</p>" + "".join(blocks))


def _plots(metrics: MetricsFile, out_dir: Path) -> str:
    names = [metrics.plots.pca_pixels, *metrics.plots.pca_features.values()]
    imgs = [uri for uri in (png_file_uri(out_dir / n) for n in names if n) if uri]
    if not imgs:
        return ""
    return ("<h2>Domain gap (PCA)</h2><p class=note>Each point is an image; colour = domain, marker = label. "
            "Overlapping clouds mean the synthetic images resemble the real ones.</p>"
            f'<div class="plots two">{"".join(f"<img src={u!r} alt=PCA>" for u in imgs)}</div>')


def _settings(metrics: MetricsFile) -> str:
    rows = [("data", metrics.data_root), ("real folder", metrics.real_dir or "—"),
            ("created", metrics.created), ("total time", f"{metrics.seconds:.1f} s")]
    if metrics.missing_variants:
        rows.append(("variants not in the data", ", ".join(metrics.missing_variants)))
    rows = [(k, escape(str(val))) for k, val in rows]
    for v, part, r in metrics.results():
        rows.append((f"model {v} / {part}", f"<code>{escape(r.model)}</code> · weights <b>{escape(r.weights)}"
                     f"</b> · train {r.train_seconds:.1f} s · predict {r.predict_seconds:.1f} s"))
    return settings_section(metrics, rows)


def _samples(metrics: MetricsFile) -> str:
    """Per class, a row of real photos (when the headline test is on them) above each variant's synthetic examples
    of that class: the first look at whether the renders resemble the photos."""
    head = headline(metrics)
    real = head[2].predictions if head and head[1] == "real" else []
    out = []
    for y, name in enumerate(CLASSES):
        photos = [p for p in real if p.y == y]
        rows = [("real photos", photos[:: max(1, len(photos) // REAL_SHOWN)][:REAL_SHOWN])] if photos else []
        rows += [(v, [x for x in e.examples if x.y == y]) for v, e in metrics.variants.items()]
        out.append(f"<h3>{name}</h3>" + "".join(
            f"<div class=grid>{''.join(thumb(x.path, escape(label)) for x in xs)}</div>" for label, xs in rows if xs))
    title = "Synthetic samples beside the real photos" if real else "Synthetic samples"
    return f"<h2>{title}</h2>" + "".join(out)


def _history(e: Variant) -> list[Epoch] | None:
    """The training history of a variant's headline test (its real-photo test, else its split); None without."""
    test = e.real or e.split
    return test.history if isinstance(test, Experiment) else None


def render_html(metrics: MetricsFile, out_dir: Path) -> str:
    """The report page as a string."""
    cms = "".join(
        _confusion(f"{v} · {'real' if part == 'real' else 'synthetic'} test", r.metrics.confusion.matrix)
        for v, part, r in metrics.results()
    )
    curves = curves_png({v: _history(e) for v, e in metrics.variants.items()})
    parts = [
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>",
        "<meta name=viewport content='width=device-width,initial-scale=1'>",
        f"<title>deformsim report</title><style>{CSS}</style></head><body><main>",
        "<h1>Deformation classifier report</h1>",
        f"<div class=sub>{escape(str(metrics.data_root))} · {escape(str(metrics.created))}</div>",
        "".join(f"<div class=warn><b>Warning:</b> {escape(line)}</div>" for line in low_synthetic(metrics)),
        _hero(metrics),
        "<h2>Results by training variant (paper, Table II)</h2>",
        "<p class=note>Deformed is the positive class. Synthetic test: a held-out part of the variant, split by "
        "scene so that no view of a test scene is seen in training. Real test: model trained on all images of "
        "the variant.</p>",
        _table2(metrics),
        _samples(metrics),
        f"<h2>Confusion matrices</h2><div class=cms>{cms}</div>" if cms else "",
        _calibration(metrics),
        fewshot_section(metrics.fewshot),
        _gradcams(metrics, out_dir),
        dense_section(metrics, out_dir),
        _plots(metrics, out_dir),
        "<h2>Training curves</h2><p class=note>Per variant, the model of the headline test (trained on all images "
        "when real photos are given, else on the split): its training loss and its accuracy on the images it held "
        "out for validation.</p><div class='plots two'>"
        + "".join(f"<img src='{data_uri(c, 'image/png')}' alt='training curves'>" for c in curves) + "</div>"
        if curves else "",
        predictions_section(headline(metrics)),
        _settings(metrics),
        "</main></body></html>",
    ]
    return "\n".join(parts)


def write_report(metrics: MetricsFile, out_dir: str | Path) -> Path:
    """Write ``out_dir/report.html`` (``metrics.json`` is run_experiments' to write); return its path."""
    out_dir = Path(out_dir)
    path = out_dir / "report.html"
    write_text(path, render_html(metrics, out_dir))
    return path
