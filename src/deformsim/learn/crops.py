"""Square views at test time (``train.crop``): ``saliency``, a square around the most salient region (the part);
``center``, the largest centred square; ``pad``, the whole image on a square whose margins are the image itself,
stretched and blurred. Each keeps the photo's aspect, which resizing a whole non-square photo to the square input
would distort (the renders are square); ``pad`` alone keeps all of the photo.

Saliency is the spectral residual of Hou and Zhang (CVPR 2007) on a 64 px grey thumbnail: the log amplitude
spectrum less its local mean, transformed back with the original phase, squared and blurred. Pixels above three
times the mean saliency (their threshold) mark the object; the box spans the 2nd to 98th percentile of them, grows
by :data:`MARGIN` of its side, is made square (at least :data:`MIN_SIDE` of the image's shorter side) and is
moved inside the image. An image without a salient pixel is kept whole (its largest centred square).
"""

from __future__ import annotations

import cv2
import numpy as np
from PIL import Image, ImageFilter

THUMB = 64
MARGIN = 0.15
MIN_SIDE = 0.4
PAD_BLUR = 0.05  # Gaussian radius of ``pad``'s margins, as a share of the square's side


def saliency_map(image: Image.Image) -> np.ndarray:
    """Spectral-residual saliency (THUMB x THUMB, float32, non-negative) of ``image``."""
    grey = np.asarray(image.convert("L").resize((THUMB, THUMB), Image.BILINEAR), dtype=np.float64)
    spectrum = np.fft.fft2(grey)
    log_amp = np.log1p(np.abs(spectrum))
    residual = log_amp - cv2.blur(log_amp, (3, 3))
    sal = np.abs(np.fft.ifft2(np.exp(residual + 1j * np.angle(spectrum)))) ** 2
    return cv2.GaussianBlur(sal, (0, 0), 2.5).astype(np.float32)


def saliency_box(image: Image.Image) -> tuple[int, int, int, int]:
    """The square crop box (left, top, right, bottom) in pixels of ``image``."""
    w, h = image.size
    sal = saliency_map(image)
    ys, xs = np.nonzero(sal >= 3 * sal.mean())
    short = min(w, h)
    if len(xs) == 0:
        cx, cy, side = w / 2, h / 2, short
    else:
        (x0, x1), (y0, y1) = np.percentile(xs, [2, 98]), np.percentile(ys, [2, 98])
        x0, x1 = x0 * w / THUMB, (x1 + 1) * w / THUMB
        y0, y1 = y0 * h / THUMB, (y1 + 1) * h / THUMB
        side = min(short, max(x1 - x0, y1 - y0, MIN_SIDE * short / (1 + 2 * MARGIN)) * (1 + 2 * MARGIN))
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    left = int(round(min(max(cx - side / 2, 0), w - side)))
    top = int(round(min(max(cy - side / 2, 0), h - side)))
    side = int(round(side))
    return left, top, left + side, top + side


def center_box(image: Image.Image) -> tuple[int, int, int, int]:
    """The largest centred square (left, top, right, bottom) of ``image``."""
    w, h = image.size
    side = min(w, h)
    left, top = (w - side) // 2, (h - side) // 2
    return left, top, left + side, top + side


def pad(image: Image.Image) -> Image.Image:
    """``image`` whole and centred on a square of its longer side, the margins filled by ``image`` stretched to the
    square and blurred (no hard band of one colour, which no training image has); a square image is unchanged."""
    w, h = image.size
    side = max(w, h)
    if w == h:
        return image
    out = image.resize((side, side), Image.BILINEAR).filter(ImageFilter.GaussianBlur(PAD_BLUR * side))
    out.paste(image, ((side - w) // 2, (side - h) // 2))
    return out


BOXES = {"saliency": saliency_box, "center": center_box}


def crop(image: Image.Image, mode: str) -> Image.Image:
    """``image`` made square as ``train.crop`` says (``none``: unchanged)."""
    if mode == "none":
        return image
    return pad(image) if mode == "pad" else image.crop(BOXES[mode](image))
