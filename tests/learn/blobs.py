"""Easy synthetic images for learning tests and bench/train.py: round blobs (intact) vs jagged stars (deformed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw


def blob(rng: np.random.Generator, jagged: bool, size: int) -> Image.Image:
    """A filled shape on a noisy background: a smooth disc-like blob or a jagged star."""
    bg = rng.integers(40, 200, 3)
    arr = np.clip(bg + rng.normal(0, 12, (size, size, 3)), 0, 255).astype(np.uint8)
    im = Image.fromarray(arr)
    c = size / 2 + rng.uniform(-size / 10, size / 10, 2)
    r = size * rng.uniform(0.25, 0.35)
    n = 24 if jagged else 64
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False) + rng.uniform(0, 1)
    rad = r * (np.where(np.arange(n) % 2, 0.45, 1.0) if jagged else rng.uniform(0.95, 1.05, n))
    pts = [(float(c[0] + q * np.cos(a)), float(c[1] + q * np.sin(a))) for a, q in zip(ang, rad)]
    ImageDraw.Draw(im).polygon(pts, fill=tuple(int(v) for v in rng.integers(0, 256, 3)))
    return im


def make_blobs(folder: Path, n_per_class: int, size: int = 64, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    for y, label in enumerate(("intact", "deformed")):
        (folder / label).mkdir(parents=True, exist_ok=True)
        for i in range(n_per_class):
            p = folder / label / f"{i:03d}.png"
            blob(rng, bool(y), size).save(p)
            rows.append({"id": f"{label}/{i:03d}", "path": str(p), "label": label, "y": y})
    return pd.DataFrame(rows)
