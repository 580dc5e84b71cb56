"""torchvision's backbones as ``features`` modules, and the ``features`` part of torchvision's weight files."""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn


def vgg16_features() -> nn.Sequential:
    """VGG-16's randomly initialised ``features``, without building its 120M-parameter classifier."""
    from torchvision.models import vgg

    features = vgg.make_layers(vgg.cfgs["D"])
    for m in features.modules():
        if isinstance(m, nn.Conv2d):  # as torchvision's VGG initialises its convolutions
            nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            nn.init.zeros_(m.bias)
    return features


def mobilenet_v2_features() -> nn.Sequential:
    from torchvision.models import mobilenet_v2

    return mobilenet_v2(weights=None).features


def features_only(state: dict) -> dict:
    """A torchvision model's state dict reduced to its ``features`` (keys ``"0.weight"`` ...)."""
    return {k.removeprefix("features."): v for k, v in state.items() if k.startswith("features.")}


def file_features(path: Path) -> dict:
    """The ``features`` state dict in a torchvision weights file."""
    return features_only(torch.load(path, map_location="cpu", weights_only=True))
