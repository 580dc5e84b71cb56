"""SSIM and PSNR: the render-quality benchmark's yardsticks."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.evaluate.image_quality import psnr, ssim


@pytest.fixture
def image():
    y, x = np.mgrid[0:64, 0:64] / 63
    return np.stack([x, y, 0.5 + 0.4 * np.sin(6 * x) * np.cos(4 * y)], axis=-1)


def test_identical_images_score_one_and_infinity(image):
    assert ssim(image, image) == pytest.approx(1.0)
    assert psnr(image, image) == float("inf")


def test_more_noise_scores_lower(image):
    rng = np.random.default_rng(0)
    noise = rng.normal(size=image.shape)
    scores = [(ssim(image, image + s * noise), psnr(image, image + s * noise)) for s in (0.01, 0.05, 0.2)]
    assert scores[0][0] > scores[1][0] > scores[2][0] and scores[0][0] < 1
    assert scores[0][1] > scores[1][1] > scores[2][1]
    assert scores[0][1] == pytest.approx(40, abs=0.2)  # sigma 0.01 -> MSE 1e-4 -> 40 dB


def test_known_values_on_flat_images():
    a, b = np.full((32, 32), 0.5), np.full((32, 32), 0.6)
    # flat images: only the luminance term is left, (2ab + C1) / (a^2 + b^2 + C1) with C1 = 0.01^2
    assert ssim(a, b) == pytest.approx((2 * 0.5 * 0.6 + 1e-4) / (0.25 + 0.36 + 1e-4))
    assert psnr(a, b) == pytest.approx(20.0)  # MSE 0.01
    assert ssim(a * 255, b * 255, data_range=255) == pytest.approx(ssim(a, b))


def test_mismatched_or_tiny_images_are_refused():
    with pytest.raises(ValueError, match="shapes differ"):
        ssim(np.zeros((32, 32)), np.zeros((32, 31)))
    with pytest.raises(ValueError, match="smaller than"):
        ssim(np.zeros((8, 8)), np.zeros((8, 8)))
