"""Heads on the backbone: the global pooling before them, the paper's classifier head (and its linear probe) and
the light region head.

The pooling (``train.pool``) turns the trainable layers' map into one vector: its mean (``avg``, the paper's), its
maximum (``max``: a local feature counts wherever it fires, however small its area) or both side by side (``avgmax``).

The region head (``train.target: localise``) reads the frozen stem's feature map: a 3x3 convolution to
:data:`REGION_WIDTH` channels, ReLU, a 1x1 convolution to one logit per cell, bilinearly upsampled to
:func:`region_size` of the input (a quarter of its side), where it is trained and scored against the region masks.
"""

from __future__ import annotations

import torch
from torch import nn

REGION_WIDTH = 64
POOL_WIDTH = {"avg": 1, "max": 1, "avgmax": 2}  # pooled vector width per feature-map channel


class GlobalPool(nn.Module):
    """Feature map (N, C, h, w) -> (N, C) (``avg``, ``max``) or (N, 2C) (``avgmax``: mean then max)."""

    def __init__(self, mode: str = "avg"):
        super().__init__()
        self.mode = mode

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        pooled = []
        if self.mode in ("avg", "avgmax"):
            pooled.append(nn.functional.adaptive_avg_pool2d(x, 1).flatten(1))
        if self.mode in ("max", "avgmax"):
            pooled.append(nn.functional.adaptive_max_pool2d(x, 1).flatten(1))
        return pooled[0] if len(pooled) == 1 else torch.cat(pooled, 1)


def region_size(image_size: int) -> int:
    """Side of the region head's output map for square inputs of ``image_size`` pixels."""
    return max(8, image_size // 4)


def vector_head(width: int, hidden: tuple[int, int], dropout: float, kind: str, outputs: int) -> nn.Sequential:
    """``mlp``: the paper's three fully connected layers; ``linear``: a linear probe; ``outputs`` logits."""
    if kind == "mlp":
        h0, h1 = hidden
        return nn.Sequential(
            nn.Flatten(),
            nn.Linear(width, h0), nn.ReLU(inplace=True), nn.Dropout(dropout),
            nn.Linear(h0, h1), nn.ReLU(inplace=True), nn.Dropout(dropout),
            nn.Linear(h1, outputs),
        )
    return nn.Sequential(nn.Flatten(), nn.Dropout(dropout), nn.Linear(width, outputs))


class RegionHead(nn.Module):
    """Feature map (N, C, h, w) -> region logits (N, size, size)."""

    def __init__(self, channels: int, size: int):
        super().__init__()
        self.size = size
        self.conv = nn.Sequential(nn.Conv2d(channels, REGION_WIDTH, 3, padding=1), nn.ReLU(inplace=True),
                                  nn.Conv2d(REGION_WIDTH, 1, 1))

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        logits = self.conv(z)
        return nn.functional.interpolate(logits, size=(self.size, self.size), mode="bilinear", align_corners=False)[:, 0]
