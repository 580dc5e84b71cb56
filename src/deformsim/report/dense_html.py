"""The report's section on the dense-label heads (``metrics.dense``, from
:func:`deformsim.evaluate.dense_experiments.run_dense`): severity, deformation families, localisation."""

from __future__ import annotations

from html import escape
from pathlib import Path

from deformsim.dataset.images import CLASSES
from deformsim.evaluate.metrics_file import Head, MetricsFile
from deformsim.report.figures import png_file_uri, thumbnail_uri


def _num(x: float | None, fmt: str = ".2f") -> str:
    return "—" if x is None else format(x, fmt)


def _severity(head: Head, out_dir: Path) -> str:
    m = head.metrics
    uri = png_file_uri(out_dir / head.plot) if head.plot else None
    img = f"<div class=plots><img src='{uri}' alt='severity scatter'></div>" if uri else ""
    return (f'<div class="card"><h3>Severity</h3><div class="mid">{_num(m.mae_mm)} mm</div>'
            f'<div>mean absolute error of the maximum displacement</div><div class="sub">RMSE {_num(m.rmse_mm)} mm · '
            f'Spearman ρ {_num(m.spearman)} · always answering the training mean: {_num(m.baseline_mae_mm)} mm · '
            f'{escape(str(m.n))} held-out images</div>{img}</div>')


def _families(head: Head) -> str:
    m = head.metrics
    rows = "".join(
        f"<tr><td>{escape(name)}</td><td>{_num(f.ap)}</td>"
        + "".join(f"<td>{_num(f.value(k))}</td>" for k in ("f1", "precision", "recall"))
        + f"<td>{escape(str(f.n_positive))}</td></tr>" for name, f in m.families.items()
    )
    return ('<div class="card"><h3>Deformation families</h3><div class=scroll><table class="t2"><tr><th>family</th>'
            f"<th>AP</th><th>F1</th><th>Prec.</th><th>Recall</th><th>test images with it</th></tr>{rows}<tr><td><b>macro</b></td>"
            f"<td><b>{_num(m.macro_ap)}</b></td><td><b>{_num(m.macro_f1)}</b></td><td></td><td></td><td></td></tr>"
            f'</table></div><div class="sub">multi-label; F1, precision and recall at probability {m.threshold:g}; '
            f"macro means over the families present in the test part; — : undefined</div></div>")


def _localise(head: Head, out_dir: Path) -> str:
    m = head.metrics
    cells = []
    for h in head.real_heatmaps or []:
        uri = thumbnail_uri(out_dir / h.image, 420)
        img = f'<img src="{uri}" alt="" style="width:100%">' if uri else '<div class="missing">missing</div>'
        cells.append(f'<div class="card" style="flex:1 1 300px;max-width:420px" title="{escape(h.path)}">{img}'
                     f'<div class=sub>{escape(Path(h.path).name)} · {CLASSES[h.y]} · predicted region '
                     f'{100 * h.region_fraction:.1f}% of the photo · peak {h.peak:.2f}</div></div>')
    photos = (f"<p class=note>Real photos (evenly spread over the folder; the label is only shown): the photo "
              f"and the predicted probability of the deformed region over it (red and yellow).</p>"
              f'<div class="hero">{"".join(cells)}</div>') if cells else ""
    return (f'<div class="card"><h3>Localisation</h3><div class="mid">IoU {_num(m.iou)}</div>'
            f'<div class="sub">pixel F1 {_num(m.pixel_f1)} · mean IoU per image {_num(m.mean_iou)} · region '
            f'{100 * m.truth_fraction:.1f}% of the pixels, predicted {100 * m.predicted_fraction:.1f}% · '
            f'probability {m.threshold:g} · {m.n} held-out images</div></div>{photos}')


def dense_section(metrics: MetricsFile, out_dir: Path) -> str:
    """The section's HTML, or "" when the dataset had no dense labels."""
    dense = metrics.dense
    if not dense:
        return ""
    title = "<h2>Dense labels: severity, deformation families, localisation</h2>"
    if dense.skipped is not None:
        return f"{title}<p class=note>Not run on <b>{escape(dense.variant)}</b>: {escape(dense.skipped)}</p>"
    heads = dense.heads
    seconds = " · ".join(f"{escape(t)} {h.train_seconds:.1f} s" for t, h in heads.items())
    intro = (f"<p class=note>Heads on the frozen backbone, trained on {escape(str(dense.n_train))} images of the "
             f"<b>{escape(dense.variant)}</b> variant and measured on the {escape(str(dense.n_test))} held out by the same "
             f"split as the synthetic test above (synthetic data). Training time (cached features): {seconds}; "
             f"{dense.seconds:.1f} s in all.</p>")
    parts = [_severity(heads["severity"], out_dir) if "severity" in heads else "",
             _families(heads["family"]) if "family" in heads else ""]
    body = f'<div class="hero">{"".join(parts)}</div>'
    return title + intro + body + (_localise(heads["localise"], out_dir) if "localise" in heads else "")
