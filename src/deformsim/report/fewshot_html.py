"""The report's few-shot section: ``bench fewshot``'s curves (:mod:`deformsim.evaluate.fewshot`) as a table and a plot."""

from __future__ import annotations

from html import escape

from deformsim.evaluate.fewshot import TITLES
from deformsim.evaluate.fewshot_file import CURVES, CurveRow, FewshotFile
from deformsim.report.figures import data_uri, fewshot_png


def _e(value: object) -> str:
    """Any value as HTML text, escaped."""
    return escape(str(value))


def _cell(row: CurveRow | None, key: str) -> str:
    cls = " class=grp" if key == "accuracy" else ""  # each curve's first column
    if row is None:
        return f"<td{cls}>—</td>"
    lo, hi = getattr(row, f"{key}_interval")
    return f"<td{cls}>{100 * getattr(row, key):.1f}%<span class=ci>{100 * lo:.1f}–{100 * hi:.1f}%</span></td>"


def fewshot_section(results: FewshotFile | None) -> str:
    """The section, or "" without results."""
    if results is None:
        return ""
    curves = [c for c in CURVES if c in results.curves]
    by_k = {c: {r.k: r for r in results.curves[c]} for c in curves}
    ks = sorted({k for rows in by_k.values() for k in rows})
    head = "".join(f'<th colspan="2" class="grp">{_e(TITLES[c])}</th>' for c in curves)
    sub = "".join("<th class=grp>Acc</th><th>F1</th>" for _ in curves)
    majority = {r.k: r.majority for rows in results.curves.values() for r in rows}
    rows = "".join(f"<tr><td><b>{_e(k)}</b></td>{''.join(_cell(by_k[c].get(k), m) for c in curves for m in ('accuracy', 'f1'))}"
                   f"<td class=grp>{100 * majority[k]:.1f}%</td></tr>" for k in ks)
    photos = results.photos
    return (
        "<h2>Few-shot adaptation with real photos</h2><p class=note>"
        f"k labelled photos of each class drawn from <code>{_e(results.real_dir)}</code> "
        f"({_e(photos.intact)} intact, {_e(photos.deformed)} deformed); the model <code>{_e(results.model)}"
        "</code> adapted on them, the model as it is, and the same backbone with ImageNet weights only trained on "
        f"them alone; all scored on the remaining photos, over {_e(results.draws)} draws × {_e(results.seeds)} seeds "
        "per k. Mean and 95 % bootstrap interval of the mean over the draws (k = 0: the model as it is, the interval "
        "over the photos). "
        "Majority class: the share of the commoner label among the photos scored at that k.</p>"
        f'<div class=scroll><table class="t2"><tr><th rowspan="2">k per class</th>{head}'
        f'<th rowspan="2" class="grp">majority class</th></tr><tr>{sub}</tr>{rows}'
        f"</table></div><div class=plots><img src='{data_uri(fewshot_png(results.curves, TITLES), 'image/png')}' "
        "alt='few-shot curves'></div>"
    )
