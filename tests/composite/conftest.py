"""Fixtures of the composite tests: a private copy of the rendered dataset and synthetic green-screen photos."""

from __future__ import annotations

import shutil

import cv2
import numpy as np
import pandas as pd
import pytest


@pytest.fixture
def dataset(tiny_dataset, tmp_path):
    """A copy of the rendered tiny dataset that a test may add variants to."""
    out = tmp_path / "data"
    shutil.copytree(tiny_dataset, out, ignore=shutil.ignore_patterns("variants"))
    return out


def with_images(src, dst, kind: str, make):
    """A copy of the dataset at ``src`` in ``dst`` with one more image per render, ``make(rgba)`` (uint8 RGBA ->
    image), in ``images/KIND/`` and a ``KIND`` manifest column, as ``render.shadow`` or ``render.surface`` add."""
    from deformsim.dataset.layout import Layout

    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("variants"))
    layout = Layout(dst)
    df = pd.read_parquet(layout.manifest)
    paths = []
    for row in df.itertuples():
        path = layout.image(kind, row.id)
        path.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(path), make(cv2.imread(str(dst / row.rgba), cv2.IMREAD_UNCHANGED)))
        paths.append(layout.rel(path))
    df.assign(**{kind: paths}).to_parquet(layout.manifest, index=False)
    return dst


def green_screen_photo(seed: int, size: int = 96, ss: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A fake photo of an object in front of a real green screen, and its exact alpha.

    Uneven, off-key screen (shading gradient, vignette, a soft shadow), a shaded can-like object with a
    lid and a dark band, green spill on its rim, sensor noise, the camera's JPEG compression, then
    resizing. No alpha channel.
    """
    rng = np.random.default_rng(seed)
    n = size * ss
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32) / n
    screen = np.array([rng.uniform(20, 60), rng.uniform(150, 200), rng.uniform(40, 80)], np.float32)
    light = (0.6 + 0.5 * (xx * rng.uniform(-1, 1) + yy * rng.uniform(-1, 1) + 1) / 2) * (
        1 - 0.5 * ((xx - 0.5) ** 2 + (yy - 0.5) ** 2)
    )
    cx, cy = rng.uniform(0.4, 0.6, 2)
    rx, ry = rng.uniform(0.15, 0.25), rng.uniform(0.25, 0.35)
    shadow = 1 - 0.3 * np.exp(-(((xx - cx - 0.12) / rx) ** 2 + ((yy - cy - 0.08) / ry) ** 2))
    img = screen * (light * shadow)[..., None]
    mask = (np.abs(xx - cx) < rx) & (np.abs(yy - cy) < ry)
    mask |= ((xx - cx) / rx) ** 2 + ((yy - cy - ry) / (0.3 * rx)) ** 2 < 1
    mask |= ((xx - cx) / rx) ** 2 + ((yy - cy + ry) / (0.3 * rx)) ** 2 < 1
    hsv = np.array([[[rng.choice([0, 15, 110, 130, 160]), rng.uniform(80, 220), 200]]], np.uint8)
    base = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0, 0].astype(np.float32)
    u = np.clip((xx - cx) / rx, -1, 1)
    shade = 0.35 + 0.65 * np.sqrt(1 - u**2) * (0.8 + 0.2 * np.cos(9 * yy))
    obj = base * shade[..., None]
    obj[np.abs(yy - cy) < 0.03] *= 0.25  # dark band
    obj[yy < cy - ry + 0.04] = (190, 190, 195)  # metal lid
    obj[..., 1] += 0.3 * screen[1] * light * (1 - np.sqrt(1 - u**2)) ** 2  # green spill on the rim
    img = np.clip(np.where(mask[..., None], obj, img) + rng.normal(0, 6, img.shape), 0, 255).astype(np.uint8)
    _, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])  # the camera's JPEG, then resized
    small = cv2.resize(cv2.imdecode(buf, cv2.IMREAD_COLOR), (size, size), interpolation=cv2.INTER_AREA)
    small = np.clip(small + rng.normal(0, 3, small.shape), 0, 255).astype(np.uint8)
    alpha = cv2.resize(mask.astype(np.float32), (size, size), interpolation=cv2.INTER_AREA)
    return small, alpha  # channel order does not matter: red and blue play symmetric roles


@pytest.fixture
def green_photo():
    return green_screen_photo
