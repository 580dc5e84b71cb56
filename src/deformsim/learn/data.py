"""Images for training and prediction: tensors (read by the package's one loader), augmentation, a torch Dataset."""

from __future__ import annotations

import math
from pathlib import Path

import torch

from deformsim.learn.model_input import model_input


def load_image(path: str | Path, size: int, crop: str = "none", flip: bool = False) -> torch.Tensor:
    """:func:`deformsim.learn.model_input.model_input` as a tensor (3, size, size): 0-1 RGB, resized to a square
    after the test-time ``crop``, mirrored with ``flip``."""
    return torch.from_numpy(model_input(path, size, crop, flip))


def augmenter(size: int):
    """Random resized crop, horizontal flip, colour jitter, and in a third of the images each a Gaussian blur and
    sensor noise (uses torch's seeded global RNG)."""
    from torchvision.transforms import v2

    return v2.Compose([
        v2.RandomResizedCrop(size, scale=(0.7, 1.0), ratio=(0.85, 1.15), antialias=True),
        v2.RandomHorizontalFlip(),
        v2.ColorJitter(brightness=0.2, contrast=0.2, saturation=0.2, hue=0.02),
        v2.RandomApply([v2.GaussianBlur(5, sigma=(0.3, 1.5))], p=1 / 3),
        v2.RandomApply([v2.GaussianNoise(sigma=0.02)], p=1 / 3),
    ])


class RandomConv:
    """Random convolution (Xu et al., ICLR 2021): with probability ``p`` an image (3, H, W) is filtered by a random
    k x k convolution mixing its channels (k from ``kernels``, He-initialised weights, reflected edges), brought back
    to the image's own mean and spread, and blended with it by a uniform weight. Shapes stay, local texture and
    colour change. Draws from torch's seeded global RNG."""

    def __init__(self, p: float, kernels: tuple[int, ...] = (1, 3, 5, 7)):
        self.p, self.kernels = p, kernels

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        if float(torch.rand(())) >= self.p:
            return x
        k = self.kernels[int(torch.randint(len(self.kernels), ()))]
        weight = torch.randn(3, 3, k, k) / math.sqrt(3 * k * k)
        pad = k // 2
        padded = torch.nn.functional.pad(x[None], [pad] * 4, mode="reflect") if pad else x[None]
        y = torch.nn.functional.conv2d(padded, weight)[0]
        y = (y - y.mean()) / (y.std() + 1e-6) * x.std() + x.mean()
        alpha = float(torch.rand(()))
        return (alpha * x + (1 - alpha) * y).clamp_(0, 1)


def training_transform(augment: bool, random_conv: float, size: int):
    """What training images go through: a random convolution in a ``random_conv`` share of them, then with ``augment``
    :func:`augmenter`; None when neither is on."""
    steps = ([RandomConv(random_conv)] if random_conv else []) + ([augmenter(size)] if augment else [])
    if not steps:
        return None
    from torchvision.transforms import v2

    return v2.Compose(steps)


class ImageSet(torch.utils.data.Dataset):
    """Images of ``paths`` as :func:`load_image` reads them (``crop``, ``flip``), then ``transform``."""

    def __init__(self, paths: list, size: int, transform=None, crop: str = "none", flip: bool = False):
        self.paths, self.size, self.transform = [str(p) for p in paths], size, transform
        self.crop, self.flip = crop, flip

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i: int) -> torch.Tensor:
        x = load_image(self.paths[i], self.size, self.crop, self.flip)
        return self.transform(x) if self.transform else x
