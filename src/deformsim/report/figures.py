"""Images for the report, returned as ``data:`` URIs so the page needs no other file."""

from __future__ import annotations

import base64
import io
from pathlib import Path

from deformsim.dataset.images import open_rgb
from deformsim.errors import UserError
from deformsim.evaluate.fewshot_file import CurveRow
from deformsim.learn.train_file import Epoch


def data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def png_file_uri(path: Path) -> str | None:
    """The PNG at ``path`` inlined, or None when it is missing."""
    return data_uri(path.read_bytes(), "image/png") if path.is_file() else None


def thumbnail_uri(path: str | Path, size: int = 120) -> str | None:
    """A JPEG thumbnail of the image at ``path`` (longest side ``size``), or None when it cannot be read."""
    try:
        im = open_rgb(path)
    except UserError:
        return None
    im.thumbnail((size, size))
    buf = io.BytesIO()
    im.save(buf, format="JPEG", quality=82)
    return data_uri(buf.getvalue(), "image/jpeg")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    _pyplot().close(fig)
    return buf.getvalue()


def _text(name: str) -> str:
    """A name as literal plot text (a ``$`` would start matplotlib's math mode)."""
    return name.replace("$", r"\$")


def curves_png(histories: dict[str, list[Epoch] | None]) -> list[bytes]:
    """Two figures, one colour per model: training loss per epoch, and accuracy on its validation images (the
    training accuracy, dashed, where it held none out); each with its legend beside the plot. [] without history."""
    histories = {k: h for k, h in histories.items() if h}
    if not histories:
        return []
    from matplotlib.ticker import MaxNLocator

    plt = _pyplot()
    no_val = any(h.val_acc is None for hist in histories.values() for h in hist)
    figures = []
    for what in ("training loss (cross-entropy)", "validation accuracy"):
        fig, ax = plt.subplots(figsize=(5.2, 3.0), dpi=110)
        for i, (name, hist) in enumerate(histories.items()):
            epochs = [h.epoch for h in hist]
            style = {"marker": "o", "ms": 3, "color": f"C{i}", "label": _text(name)}
            if what.startswith("training"):
                ax.plot(epochs, [h.loss for h in hist], **style)
            elif val := [(e, h.val_acc) for e, h in zip(epochs, hist) if h.val_acc is not None]:
                ax.plot(*zip(*val), **style)
            else:
                ax.plot(epochs, [h.acc for h in hist], ls="--", **style)
        if what.startswith("validation"):
            ax.set_ylim(0, 1.02)
            if no_val:
                ax.plot([], [], ls="--", color="#888", label="dashed: training accuracy\n(no validation images)")
        epochs = [h.epoch for hist in histories.values() for h in hist]
        ax.set_xlim(min(epochs) - 0.5, max(epochs) + 0.5)
        ax.set_xlabel("epoch")
        ax.set_ylabel(what, fontsize=9)
        ax.grid(alpha=0.25)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        ax.legend(fontsize=8, frameon=False, loc="upper left", bbox_to_anchor=(1.02, 1), borderaxespad=0)
        figures.append(_png(fig))
    return figures


def reliability_png(diagrams: dict[str, dict]) -> bytes:
    """One reliability diagram per name (values from :func:`deformsim.evaluate.calibration.reliability`): per bin
    the observed share of deformed images (blue), its gap to the mean predicted probability (hatched red) and its
    number of images; the diagonal (dashed) is perfect calibration."""
    plt = _pyplot()
    cols = min(len(diagrams), 4)
    rows = -(-len(diagrams) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.4 * rows), dpi=150, squeeze=False)
    for ax, (name, d) in zip(axes.flat, diagrams.items()):
        full = [b for b in d["bins"] if b["n"]]
        lo, width = [b["lo"] for b in full], [b["hi"] - b["lo"] for b in full]
        freq, prob = [b["freq"] for b in full], [b["prob"] for b in full]
        ax.plot([0, 1], [0, 1], ls="--", lw=1, color="#888")
        ax.bar(lo, freq, width, align="edge", color="#4c78a8", edgecolor="white")
        ax.bar(lo, [p - f for p, f in zip(prob, freq)], width, bottom=freq, align="edge", fill=False, hatch="////",
               edgecolor="#d0342c", lw=0.6)
        for b in full:
            ax.text((b["lo"] + b["hi"]) / 2, max(b["freq"], b["prob"]) + 0.02, str(b["n"]), ha="center", fontsize=9)
        ax.set_title(f"{_text(name)}\nECE {d['ece']:.3f} · {d['n']} predictions", fontsize=11)
        ax.set(xlim=(0, 1), ylim=(0, 1.1))
        ax.set_xlabel("predicted P(deformed)", fontsize=10)
        ax.set_ylabel("observed share deformed", fontsize=10)
        ax.tick_params(labelsize=9)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    for ax in axes.flat[len(diagrams):]:
        ax.axis("off")
    return _png(fig)


def error_bars_png(groups: list[str], series: dict[str, list[tuple[float, float, list[float]]]],
                   reference: tuple[float, str] | None = None) -> bytes:
    """Grouped bars: per group, one bar per series at its mean with a +-std error bar and a dot per value.

    ``series`` maps a name to one ``(mean, std, values)`` per group; ``reference`` (value, label) is drawn as a
    dashed line over the first group.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(min(12, 3 + len(groups) * (0.5 + 0.35 * len(series))), 3.6), dpi=110)
    width = 0.8 / len(series)
    for i, (name, cells) in enumerate(series.items()):
        x = [g - 0.4 + width * (i + 0.5) for g in range(len(groups))]
        ax.bar(x, [c[0] for c in cells], width * 0.9, yerr=[c[1] for c in cells], capsize=3, alpha=0.85,
               label=_text(name), error_kw={"lw": 1})
        for xi, (_, _, values) in zip(x, cells):
            offsets = [width * 0.6 * ((k + 0.5) / len(values) - 0.5) for k in range(len(values))]
            ax.plot([xi + o for o in offsets], values, "o", ms=2.5, color="#1d2433", alpha=0.6)
    if reference is not None:
        ax.hlines(reference[0], -0.45, 0.45, colors="#555", linestyles="--", lw=1.2, label=_text(reference[1]))
    ax.set_xticks(range(len(groups)), [_text(g) for g in groups], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.grid(axis="y", alpha=0.25)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    ax.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1, 1))
    return _png(fig)


def fewshot_png(curves: dict[str, list[CurveRow]], titles: dict[str, str]) -> bytes:
    """Accuracy and F1 against the photos per class adapted on (``bench fewshot``'s ``curves``): one line per curve
    (named by ``titles``) with its 95 % interval as a band, and under accuracy the majority-class share of the
    photos scored at each k (dashed)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.4), dpi=110)
    for ax, key, label in zip(axes, ("accuracy", "f1"), ("accuracy", "F1 (deformed = positive)")):
        for i, (curve, rows) in enumerate(curves.items()):
            k = [r.k for r in rows]
            lo, hi = zip(*(getattr(r, f"{key}_interval") for r in rows)) if rows else ((), ())
            ax.fill_between(k, lo, hi, color=f"C{i}", alpha=0.18, lw=0)
            ax.plot(k, [getattr(r, key) for r in rows], "o-", ms=3.5, color=f"C{i}", label=_text(titles.get(curve, curve)))
        if key == "accuracy":
            rows = min(curves.values(), key=lambda rows: -len(rows))  # the one with most k
            ax.plot([r.k for r in rows], [r.majority for r in rows], ls="--", lw=1, color="#888",
                    label="majority class of the photos scored")
        ax.set(ylim=(0, 1.02), xlabel="labelled real photos per class adapted on (k)")
        ax.set_ylabel(label, fontsize=9)
        ax.set_xticks(sorted({r.k for rows in curves.values() for r in rows}))
        ax.grid(alpha=0.25)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    axes[0].legend(fontsize=7, frameon=False, loc="lower right")
    return _png(fig)


def scatter_png(true, pred, what: str) -> bytes:
    """Predicted against true values (one dot per image) with the identity line."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(3.6, 3.4), dpi=110)
    top = max(max(true, default=1.0), max(pred, default=1.0)) * 1.05 or 1.0
    low = min(0.0, min(pred, default=0.0))
    ax.plot([low, top], [low, top], ls="--", lw=1, color="#888")
    ax.plot(true, pred, "o", ms=3.5, alpha=0.7, color="#4c78a8")
    ax.set(xlim=(low, top), ylim=(low, top), xlabel=f"true {_text(what)}", ylabel=f"predicted {_text(what)}")
    ax.xaxis.label.set_fontsize(8)
    ax.yaxis.label.set_fontsize(8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.25)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    return _png(fig)
