"""The report's lists of photos: thumbnails with captions, and the headline model's predictions, each photo linked
to its full-size file."""

from __future__ import annotations

from html import escape
from pathlib import Path

from deformsim.dataset.images import CLASSES
from deformsim.evaluate.experiments import review_order
from deformsim.evaluate.metrics_file import Experiment, Prediction
from deformsim.report.figures import thumbnail_uri

MAX_THUMBS = 12  # right predictions shown, least confident first


def thumb(path: str | Path, caption: str, cls: str = "", size: int = 120, title: str | None = None) -> str:
    """A card with the image at ``path`` (longest side ``size``) and ``caption`` (HTML); its tooltip ``title``."""
    uri = thumbnail_uri(path, size)
    img = f'<img src="{uri}" alt="">' if uri else '<div class="missing">missing</div>'
    return f'<div class="thumb {cls}" title="{escape(str(title or path))}">{img}{caption}</div>'


def photo_link(path: str) -> str:
    """A link to the full-size image at ``path`` (a ``file:`` URI, escaped)."""
    return escape(Path(path).resolve().as_uri())


def wrong_table(wrong: list[dict]) -> str:
    """Photos wrong in some runs: thumbnail and file name, each a link to the full-size image, label, in how many
    runs each was wrong (its ``wrong`` of ``runs``) and its mean P(deformed)."""
    if not wrong:
        return '<p class="note">none</p>'
    rows = []
    for p in wrong:
        uri = thumbnail_uri(p["path"], 64)
        img = f'<img src="{uri}" alt="">' if uri else '<div class="missing" style="width:64px;height:64px">?</div>'
        link = photo_link(p["path"])
        count = f'<td>{escape(str(p["wrong"]))} of {escape(str(p["runs"]))}</td>'
        rows.append(f'<tr><td><a href="{link}">{img}</a></td><td class=name><a href="{link}">{escape(Path(p["path"]).name)}</a>'
                    f'</td><td>{CLASSES[p["y"]]}</td>{count}<td>{p["prob"]:.3f}</td></tr>')
    head = "<th>wrong in runs</th><th>mean P(deformed)</th>"
    return ('<div class=scroll><table class="wrong"><tr><th>photo</th><th>file (full size)</th><th>true label</th>'
            f'{head}</tr>{"".join(rows)}</table></div>')


def _card(p: Prediction, cls: str) -> str:
    """A prediction as a card: the photo, its true label, P(deformed) and its file name, a link to the full size."""
    link = photo_link(p.path)
    return thumb(p.path, f'{CLASSES[p.y]}<br>P(deformed) = {p.prob:.3f}'
                 f'<div class=sub><a href="{link}">{escape(Path(p.path).name)}</a></div>', cls)


def predictions_section(head: tuple[str, str, Experiment] | None) -> str:
    """The predictions of the headline model ``(variant, part, result)``: every wrong one, then the least confident
    right ones, as cards of one size; "" without one."""
    if head is None:
        return ""
    v, part, r = head
    preds = r.predictions
    thr = r.metrics.threshold
    order = [preds[i] for i in review_order(preds, thr)]  # most confident mistakes, then least confident successes
    wrong = [p for p in order if (p.prob >= thr) != bool(p.y)]
    right = order[len(wrong):]
    where = "real photographs" if part == "real" else "held-out synthetic images"
    shown = right[:MAX_THUMBS]
    title = f"Right ({len(right)})" + (f": the {len(shown)} least confident" if len(shown) < len(right) else "")

    def grid(items: list[Prediction], cls: str) -> str:
        return f'<div class="grid">{"".join(_card(p, cls) for p in items)}</div>' if items else '<p class="note">none</p>'

    return (f"<h2>Predictions on {where}</h2><p class=note>Model trained on <b>{escape(v)}</b>; the true label and "
            f"the predicted probability of <i>deformed</i> (threshold {thr:g}); each file name links to the full-size "
            f"image.</p><h3>Wrong ({len(wrong)}), most confident first</h3>{grid(wrong, 'bad')}<h3>{title}</h3>"
            + grid(shown, "ok"))
