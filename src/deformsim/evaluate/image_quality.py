"""Full-reference image quality: SSIM (Wang et al. 2004, 11x11 Gaussian window, sigma 1.5) and PSNR.

Images are float arrays in [0, ``data_range``], HxW or HxWxC (SSIM is the mean over channels).
"""

from __future__ import annotations

import numpy as np

K1, K2, SIGMA, RADIUS = 0.01, 0.03, 1.5, 5
_TAPS = np.exp(-0.5 * (np.arange(-RADIUS, RADIUS + 1) / SIGMA) ** 2)
_TAPS /= _TAPS.sum()


def _blur(x: np.ndarray) -> np.ndarray:
    """Separable Gaussian filter, 'valid' region only (no padding): HxW -> (H-10)x(W-10)."""
    n = 2 * RADIUS
    rows = sum(w * x[i : x.shape[0] - n + i] for i, w in enumerate(_TAPS))
    return sum(w * rows[:, i : x.shape[1] - n + i] for i, w in enumerate(_TAPS))


def _check(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image shapes differ: {a.shape} vs {b.shape}")
    if a.shape[0] <= 2 * RADIUS or a.shape[1] <= 2 * RADIUS:
        raise ValueError(f"images of {a.shape[:2]} pixels are smaller than the {2 * RADIUS + 1}-pixel SSIM window")
    return a, b


def ssim(a: np.ndarray, b: np.ndarray, data_range: float = 1.0) -> float:
    """Mean structural similarity of ``a`` and ``b`` (1.0 for identical images)."""
    a, b = _check(a, b)
    if a.ndim == 3:
        return float(np.mean([ssim(a[..., c], b[..., c], data_range) for c in range(a.shape[2])]))
    c1, c2 = (K1 * data_range) ** 2, (K2 * data_range) ** 2
    mu_a, mu_b = _blur(a), _blur(b)
    var_a = _blur(a * a) - mu_a**2
    var_b = _blur(b * b) - mu_b**2
    cov = _blur(a * b) - mu_a * mu_b
    num = (2 * mu_a * mu_b + c1) * (2 * cov + c2)
    den = (mu_a**2 + mu_b**2 + c1) * (var_a + var_b + c2)
    return float(np.mean(num / den))


def psnr(a: np.ndarray, b: np.ndarray, data_range: float = 1.0) -> float:
    """Peak signal-to-noise ratio in dB (inf for identical images)."""
    a, b = _check(a, b)
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0 else float(10 * np.log10(data_range**2 / mse))
