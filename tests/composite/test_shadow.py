"""Composite with shadow maps (render.shadow): the background darkens under the part's shadow, nowhere else."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd

from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.layout import Layout
from tests.composite.conftest import with_images


def _ring(rgba):
    alpha = rgba[..., 3]
    ring = cv2.dilate((alpha > 0).astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool) & (alpha < 255)
    return np.where(ring, 200, 0).astype(np.uint8)


def _with_shadows(src, dst):
    """A copy of the dataset at ``src`` with a made-up shadow map per image: 200 in a ring around the part."""
    return with_images(src, dst, "shadow", _ring)


def _images(variant):
    return {p.name: cv2.imread(str(p)).astype(int) for p in sorted((variant / "images").glob("*.png"))}


def test_shadow_darkens_background_next_to_part_only(dataset, tmp_path):
    shaded = _with_shadows(dataset, tmp_path / "shaded")
    cfg = CompositeConfig(matte="alpha", workers=1)
    plain = _images(composite(dataset, cfg, "a", seed=3, progress=False).folder)
    dark = _images(composite(shaded, cfg, "a", seed=3, progress=False).folder)
    manifest = pd.read_parquet(shaded / "variants" / "a" / "manifest.parquet")
    assert (manifest["shadow_strength"] == 1.0).all()
    for name, img in dark.items():
        iid = name.removesuffix(".png")
        alpha = cv2.imread(str(Layout(shaded).image("rgba", iid)), cv2.IMREAD_UNCHANGED)[..., 3]
        shadow = cv2.imread(str(Layout(shaded).image("shadow", iid)), cv2.IMREAD_UNCHANGED)
        far = shadow == 0
        assert np.array_equal(img[far], plain[name][far])  # everything the shadow does not reach is unchanged
        near = (shadow > 0) & (alpha == 0)
        assert near.any() and (img[near] <= plain[name][near]).all()
        assert img[near].mean() < 0.5 * plain[name][near].mean() + 1  # 1 - 200/255 of the background left


def test_shadow_follows_framing_and_flip_and_strength_is_drawn(dataset, tmp_path):
    shaded = _with_shadows(dataset, tmp_path / "shaded")
    cfg = CompositeConfig(matte="alpha", workers=1, object_fill=(0.5, 0.7), flip_part=1.0, shadow_strength=(0.3, 0.9))
    plain = _images(composite(dataset, cfg, "a", seed=3, progress=False).folder)
    dark = _images(composite(shaded, cfg, "a", seed=3, progress=False).folder)
    a = pd.read_parquet(dataset / "variants" / "a" / "manifest.parquet")
    b = pd.read_parquet(shaded / "variants" / "a" / "manifest.parquet")
    assert b["shadow_strength"].between(0.3, 0.9).all() and b["shadow_strength"].nunique() > 1
    pd.testing.assert_frame_equal(a, b.drop(columns="shadow_strength"))  # no other draw moved
    for name, img in dark.items():
        assert (img <= plain[name]).all() and (img < plain[name]).any()  # only darker, somewhere
        changed = (img != plain[name]).any(-1)
        assert not changed[:3, :3].any() and not changed[-3:, -3:].any()  # far corners untouched


def test_chroma_matte_ignores_shadows(dataset, tmp_path):
    shaded = _with_shadows(dataset, tmp_path / "shaded")
    cfg = CompositeConfig(workers=1)
    assert cfg.matte == "chroma"
    one = _images(composite(dataset, cfg, "c", seed=1, progress=False).folder)
    two = _images(composite(shaded, cfg, "c", seed=1, progress=False).folder)
    assert one.keys() == two.keys() and all(np.array_equal(one[k], two[k]) for k in one)
    assert "shadow_strength" not in pd.read_parquet(shaded / "variants" / "c" / "manifest.parquet").columns
