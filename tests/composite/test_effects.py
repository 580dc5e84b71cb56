"""Camera effects: deterministic per seed, recorded, and each one does what its name says."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.composite.effects import apply_effects
from deformsim.config import CameraEffects

OFF = dict.fromkeys(CameraEffects.model_fields)


def _img(seed=0):
    rng = np.random.default_rng(seed)
    img = np.full((64, 64, 3), 128, np.uint8)
    img[16:48, 16:48] = rng.integers(0, 255, (32, 32, 3), dtype=np.uint8)
    return img


def test_effects_are_deterministic_per_seed_and_recorded():
    fx = CameraEffects()
    a, info_a = apply_effects(_img(), fx, np.random.default_rng([3, 5]))
    b, info_b = apply_effects(_img(), fx, np.random.default_rng([3, 5]))
    c, _ = apply_effects(_img(), fx, np.random.default_rng([3, 6]))
    assert np.array_equal(a, b) and info_a == info_b and not np.array_equal(a, c)
    assert set(info_a) == {"fx_exposure", "fx_white_balance", "fx_vignette", "fx_blur", "fx_noise", "fx_jpeg_quality"}


def test_all_off_leaves_the_image_alone():
    img = _img()
    out, info = apply_effects(img, CameraEffects(**OFF), np.random.default_rng(0))
    assert np.array_equal(out, img) and info == {}


def test_exposure_brightens_and_white_balance_warms():
    img = _img()
    up, _ = apply_effects(img, CameraEffects(**{**OFF, "exposure": (1.0, 1.0)}), np.random.default_rng(0))
    assert up.mean() > img.mean() + 20
    warm, _ = apply_effects(img, CameraEffects(**{**OFF, "white_balance": (0.1, 0.1)}), np.random.default_rng(0))
    assert warm[..., 0].mean() > img[..., 0].mean() and warm[..., 2].mean() < img[..., 2].mean()


def test_blur_and_noise_change_local_contrast_as_expected():
    img = _img()
    blur, _ = apply_effects(img, CameraEffects(**{**OFF, "blur": (0.03, 0.03)}), np.random.default_rng(0))
    noisy, _ = apply_effects(img, CameraEffects(**{**OFF, "noise": (0.05, 0.05)}), np.random.default_rng(0))
    flat = (slice(0, 12), slice(0, 12))  # a flat grey corner
    def edges(a):
        return np.abs(np.diff(a[16:48, 16:48].astype(float), axis=1)).mean()

    assert edges(blur) < edges(img) / 2
    assert noisy[flat].std() > 8 and img[flat].std() == 0


def test_motion_blur_smears_along_its_direction_only():
    img = np.zeros((64, 64, 3), np.uint8)
    img[32, 32] = 255  # a point light
    fx = CameraEffects(**{**OFF, "motion_blur": (0.15, 0.15)})
    out, info = apply_effects(img, fx, np.random.default_rng(1))
    again, _ = apply_effects(img, fx, np.random.default_rng(1))
    assert np.array_equal(out, again) and info["fx_motion_blur"] == pytest.approx(0.15 * 64)
    ys, xs = np.nonzero(out[..., 0] > 0)
    t = np.radians(info["fx_motion_angle"])
    along = (xs - 32) * np.cos(t) + (ys - 32) * np.sin(t)
    across = -(xs - 32) * np.sin(t) + (ys - 32) * np.cos(t)
    assert np.ptp(along) >= 0.15 * 64 - 2 and np.abs(across).max() <= 1.5  # a streak 9.6 px long, 1-2 px wide
    assert abs(float(np.average(along, weights=out[ys, xs, 0]))) < 0.5  # centred: the image does not shift
