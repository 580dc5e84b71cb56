"""Images for the report, returned as ``data:`` URIs so the page needs no other file."""

from __future__ import annotations

import base64
import io
from pathlib import Path

from PIL import Image


def data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def png_file_uri(path: Path) -> str | None:
    """The PNG at ``path`` inlined, or None when it is missing."""
    return data_uri(path.read_bytes(), "image/png") if path.is_file() else None


def thumbnail_uri(path: str | Path, size: int = 120) -> str | None:
    """A JPEG thumbnail of the image at ``path`` (longest side ``size``), or None when it cannot be read."""
    try:
        with Image.open(path) as im:
            im = im.convert("RGB")
            im.thumbnail((size, size))
            buf = io.BytesIO()
            im.save(buf, format="JPEG", quality=82)
    except (OSError, ValueError):
        return None
    return data_uri(buf.getvalue(), "image/jpeg")


def curves_png(histories: dict[str, list[dict]]) -> bytes | None:
    """Loss and accuracy per epoch, one colour per model (dashed: validation); None without history."""
    histories = {k: h for k, h in histories.items() if h}
    if not histories:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), dpi=110)
    for name, hist in histories.items():
        epochs = [h["epoch"] for h in hist]
        color = None
        for ax, key in zip(axes, ("loss", "acc")):
            line = ax.plot(epochs, [h[key] for h in hist], marker="o", ms=3, color=color, label=f"{name} train")[0]
            color = line.get_color()
            val = [(e, h.get(f"val_{key}")) for e, h in zip(epochs, hist) if h.get(f"val_{key}") is not None]
            if val:
                ax.plot(*zip(*val), ls="--", marker="s", ms=3, color=color, label=f"{name} validation")
    epochs = [h["epoch"] for hist in histories.values() for h in hist]
    for ax, what in zip(axes, ("loss", "accuracy")):
        ax.set_xlim(min(epochs) - 0.5, max(epochs) + 0.5)
        ax.set_title(what, fontsize=10)
        ax.set_xlabel("epoch")
        ax.grid(alpha=0.25)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    axes[1].set_ylim(0, 1.02)
    axes[1].legend(fontsize=7, frameon=False, loc="lower right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()
