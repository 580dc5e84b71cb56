"""Mattes: the chroma key against the exact render alpha, on renders and on fake real green-screen photos."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd

from deformsim.composite.matte import binary_iou, chroma_matte, inrange_matte
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig

CFG = CompositeConfig()


def _rgb(path) -> np.ndarray:
    return cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2RGB)


def _key_like(rgb: np.ndarray, tol: int = 60) -> np.ndarray:
    """Pixels the paper's key would call screen: within ``tol`` of pure (0, 255, 0)."""
    return cv2.inRange(rgb, (0, 255 - tol, 0), (tol, 255, tol)) > 0


def test_chroma_matches_exact_alpha_on_renders(tiny_dataset):
    df = pd.read_parquet(tiny_dataset / "manifest.parquet")
    ious, paper = [], []
    for row in df.itertuples():
        alpha = cv2.imread(str(tiny_dataset / row.rgba), cv2.IMREAD_UNCHANGED)[..., 3] / 255.0
        green = _rgb(tiny_dataset / row.green)
        ious.append(binary_iou(chroma_matte(green, CFG)[0], alpha))
        paper.append(binary_iou(inrange_matte(green, CFG)[0], alpha))
    assert min(ious) >= 0.98, ious
    assert np.mean(ious) > np.mean(paper)  # the soft key beats the paper's hard key


def test_composites_have_no_green(dataset):
    variant = composite(dataset, CFG, None, seed=1, progress=False).folder
    df = pd.read_parquet(variant / "manifest.parquet")
    assert len(df) == 8 and df["matte_iou"].min() >= 0.98
    for row in df.itertuples():
        out = _rgb(dataset / row.image)
        assert out.shape[:2] == _rgb(dataset / "images" / "green" / f"{row.id}.png").shape[:2]
        assert not _key_like(out).any(), f"{row.image} has screen-green pixels"
        assert not (out == (0, 255, 0)).all(-1).any()


def test_chroma_on_real_green_screen_photos(green_photo):
    for seed in range(6):
        rgb, alpha = green_photo(seed)
        a, fg = chroma_matte(rgb, CFG)
        assert binary_iou(a, alpha) >= 0.97, seed
        assert binary_iou(inrange_matte(rgb, CFG)[0], alpha) < 0.6  # off-key, uneven screen: hard key fails
        out = fg + (1 - a[..., None]) * 128.0  # on grey
        dominance = out[..., 1] - np.maximum(out[..., 0], out[..., 2])
        screen = (rgb[..., 1].astype(float) - np.maximum(rgb[..., 0], rgb[..., 2]))[alpha == 0]
        # nothing left that the key's own tolerance would still call screen
        assert dominance.max() < (1 - CFG.tolerance / 255) * np.median(screen), seed


def test_soft_edge_and_range(green_photo):
    rgb, alpha = green_photo(3)
    a, fg = chroma_matte(rgb, CFG)
    assert a.dtype == np.float32 and 0 <= a.min() and a.max() <= 1
    assert ((a > 0.05) & (a < 0.95)).sum() > 20  # a soft edge, not a binary mask
    assert (fg <= 255 * a[..., None] + 1e-3).all()  # premultiplied


def test_no_screen_and_all_screen():
    grey = np.full((32, 32, 3), 120, np.uint8)
    assert (chroma_matte(grey, CFG)[0] == 1).all()
    green = np.zeros((32, 32, 3), np.uint8)
    green[..., 1] = 255
    assert (chroma_matte(green, CFG)[0] == 0).all()


def test_other_key_colour(green_photo):
    rgb, alpha = green_photo(1)
    blue = rgb[..., [0, 2, 1]]  # the same scene in front of a blue screen
    a, _ = chroma_matte(blue, CompositeConfig(key_color=(0, 0, 255)))
    assert binary_iou(a, alpha) >= 0.95


def test_morphology_settings_act(green_photo):
    rgb, _ = green_photo(2)
    speck = rgb.copy()
    speck[5:7, 5:7] = (200, 40, 40)  # a red speck on the screen
    assert chroma_matte(speck, CFG)[0][5:7, 5:7].max() == 0  # opened away
    assert chroma_matte(speck, CFG.model_copy(update={"open_kernel": 0}))[0][5:7, 5:7].max() > 0.5
