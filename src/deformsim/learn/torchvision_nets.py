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


def resnet50_features() -> nn.Sequential:
    """ResNet-50 as a flat sequence: [0..3] conv1, bn1, relu, maxpool, then the 16 bottlenecks of layer1..layer4
    ([4..6], [7..10], [11..16], [17..19])."""
    from torchvision.models import resnet50

    net = resnet50(weights=None)
    blocks = [b for layer in (net.layer1, net.layer2, net.layer3, net.layer4) for b in layer]
    return nn.Sequential(net.conv1, net.bn1, net.relu, net.maxpool, *blocks)


RESNET50_FIRST = {"layer1": 4, "layer2": 7, "layer3": 11, "layer4": 17}  # index of each layer's first bottleneck


def resnet50_state(state: dict) -> dict:
    """torchvision's ResNet-50 state dict as a :func:`resnet50_features` one (``fc`` left out)."""
    out = {}
    for key, value in state.items():
        head, _, rest = key.partition(".")
        if head in ("conv1", "bn1"):
            out[f"{('conv1', 'bn1').index(head)}.{rest}"] = value
        elif head in RESNET50_FIRST:
            block, _, rest = rest.partition(".")
            out[f"{RESNET50_FIRST[head] + int(block)}.{rest}"] = value
    return out


def convnext_tiny_features() -> nn.Sequential:
    """ConvNeXt-T's ``features`` with its last stage flattened: [0..6] stem, stages 1-3 and the downsamplings,
    [7..9] the last stage's three blocks."""
    from torchvision.models import convnext_tiny

    features = convnext_tiny(weights=None).features
    return nn.Sequential(*features[:7], *features[7])


def convnext_tiny_state(state: dict) -> dict:
    """torchvision's ConvNeXt-T state dict as a :func:`convnext_tiny_features` one (the classifier left out)."""
    out = {}
    for key, value in features_only(state).items():
        stage, _, rest = key.partition(".")
        if stage == "7":
            block, _, rest = rest.partition(".")
            out[f"{7 + int(block)}.{rest}"] = value
        else:
            out[key] = value
    return out


def efficientnet_v2_s_features() -> nn.Sequential:
    from torchvision.models import efficientnet_v2_s

    return efficientnet_v2_s(weights=None).features
