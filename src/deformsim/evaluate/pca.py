"""2-D PCA of the image domains (synthetic variants, real photographs), as in the paper's domain-gap figure.

Two views: raw pixels (each image resized to ``size`` x ``size`` RGB and flattened) and the trained network's
features (``Predictor.features``). Colour marks the domain, the marker the label. Plots come back as PNG bytes.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
from PIL import Image

from deformsim.dataset.images import CLASSES, open_rgb

MAX_PER_DOMAIN = 200
MARKERS = {y: (marker, CLASSES[y]) for y, marker in enumerate(("o", "^"))}
COLORS = ("#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#17becf", "#7f7f7f")
REAL_COLOR = "#d62728"


def pixel_vectors(paths, size: int = 32) -> np.ndarray:
    """One row per image: its pixels resized to ``size`` x ``size`` RGB, scaled to [0, 1]."""
    rows = []
    for p in paths:
        rows.append(np.asarray(open_rgb(p).resize((size, size), Image.BILINEAR), dtype=np.float32))
    return np.stack(rows).reshape(len(rows), -1) / 255.0


def project_2d(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PCA to two components: (coordinates n x 2, explained variance ratio of the two)."""
    x = np.asarray(x, dtype=np.float64)
    centred = x - x.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    var = s**2
    k = min(2, len(s))
    coords = np.zeros((len(x), 2))
    coords[:, :k] = centred @ vt[:k].T
    ratio = np.zeros(2)
    ratio[:k] = var[:k] / var.sum() if var.sum() else 0.0
    return coords, ratio


def _subsample(domains: dict[str, pd.DataFrame], seed: int) -> dict[str, pd.DataFrame]:
    rng = np.random.default_rng(seed)
    out = {}
    for name, df in domains.items():
        keep = np.sort(rng.choice(len(df), size=min(MAX_PER_DOMAIN, len(df)), replace=False))
        out[name] = df.iloc[keep]
    return out


def domain_plot(coords: np.ndarray, domain: list[str], y: np.ndarray, ratio: np.ndarray, title: str) -> bytes:
    """Scatter ``coords`` coloured by ``domain``, marker by ``y``; PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    domain, y = np.asarray(domain), np.asarray(y)
    fig, ax = plt.subplots(figsize=(5.2, 4.0), dpi=110)
    palette = iter(COLORS)
    for name in dict.fromkeys(domain.tolist()):
        color = REAL_COLOR if name == "real" else next(palette, "#333333")
        for label, (marker, text) in MARKERS.items():
            m = (domain == name) & (y == label)
            if m.any():
                ax.scatter(coords[m, 0], coords[m, 1], c=color, marker=marker, s=26, alpha=0.75,
                           edgecolors="white", linewidths=0.4, label=f"{name}, {text}")
    ax.set_xlabel(f"PC1 ({ratio[0]:.0%} of variance)")
    ax.set_ylabel(f"PC2 ({ratio[1]:.0%} of variance)")
    ax.set_title(title, fontsize=11)
    ax.legend(fontsize=7, frameon=False, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    ax.grid(alpha=0.25)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def _plot(domains: dict[str, pd.DataFrame], vectors, title: str, seed: int) -> bytes:
    domains = _subsample(domains, seed)
    x = np.concatenate([vectors(list(df["path"])) for df in domains.values()])
    names = [n for n, df in domains.items() for _ in range(len(df))]
    y = np.concatenate([df["y"].to_numpy() for df in domains.values()])
    coords, ratio = project_2d(x.reshape(len(x), -1))
    return domain_plot(coords, names, y, ratio, title)


def pixel_pca_png(domains: dict[str, pd.DataFrame], size: int = 32, seed: int = 0) -> bytes:
    """PCA of raw pixels of every domain (tables with ``path`` and ``y``), at most 200 images each."""
    return _plot(domains, lambda paths: pixel_vectors(paths, size), f"PCA of pixels ({size}x{size} RGB)", seed)


def feature_pca_png(predictor, domains: dict[str, pd.DataFrame], title: str = "", seed: int = 0) -> bytes:
    """PCA of the network features ``predictor.features(paths)`` of every domain."""
    return _plot(domains, predictor.features, f"PCA of network features{': ' + title if title else ''}", seed)
