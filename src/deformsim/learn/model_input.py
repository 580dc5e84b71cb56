"""The model's input image as numpy (no torch): what a trained model and its ONNX export both read."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from deformsim.dataset.images import open_rgb


def model_input(path: str | Path, size: int, crop: str = "none", flip: bool = False) -> np.ndarray:
    """0-1 RGB float32 (3, size, size); the image is resized (not cropped) to a square, as in the paper, after
    the test-time ``crop`` (:func:`deformsim.learn.crops.crop`), and mirrored left to right with ``flip``.

    Any file mode reads as the same 8-bit sRGB RGB (:func:`deformsim.dataset.images.open_rgb`).
    """
    im = open_rgb(path)
    if crop != "none":
        from deformsim.learn.crops import crop as crop_image

        im = crop_image(im, crop)
    x = np.asarray(im.resize((size, size), Image.BILINEAR)).transpose(2, 0, 1).astype(np.float32, order="C")
    x /= np.float32(255)
    return np.ascontiguousarray(x[..., ::-1]) if flip else x
