"""Images for training and prediction: tensors (read by the package's one loader), augmentation, a torch Dataset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from PIL import Image

from deformsim.dataset.images import open_rgb


def load_image(path: str | Path, size: int) -> torch.Tensor:
    """0-1 RGB float tensor (3, size, size); the image is resized (not cropped) to a square, as in the paper.

    Any file mode reads as the same 8-bit sRGB RGB (:func:`deformsim.dataset.images.open_rgb`).
    """
    im = open_rgb(path).resize((size, size), Image.BILINEAR)
    return torch.from_numpy(np.asarray(im).copy()).permute(2, 0, 1).float().div_(255)


def augmenter(size: int):
    """Random resized crop, horizontal flip and small colour jitter (uses torch's seeded global RNG)."""
    from torchvision.transforms import v2

    return v2.Compose([
        v2.RandomResizedCrop(size, scale=(0.8, 1.0), ratio=(0.9, 1.1), antialias=True),
        v2.RandomHorizontalFlip(),
        v2.ColorJitter(brightness=0.15, contrast=0.15, saturation=0.15, hue=0.02),
    ])


class ImageSet(torch.utils.data.Dataset):
    def __init__(self, paths: list, size: int, transform=None):
        self.paths, self.size, self.transform = [str(p) for p in paths], size, transform

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i: int) -> torch.Tensor:
        x = load_image(self.paths[i], self.size)
        return self.transform(x) if self.transform else x
