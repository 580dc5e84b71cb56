"""torchvision backbones: their ``features`` modules and where the model splits them into frozen and trained.

``CUTS`` gives, per backbone and ``train.finetune`` choice, the index of the first trainable module in
``features``: vgg16 features[28] is the last conv (512->512) and features[24] starts its last block
(conv5_1..conv5_3); mobilenet_v2 features[18] is the final 1x1 conv (320->1280 + BN + ReLU6) and features[17]
its last inverted residual. ``WIDTH`` is the number of channels ``features`` outputs, ``STEM_WIDTH`` (per backbone
and cut) the number entering the first trainable module.
"""

from __future__ import annotations

from torch import nn

CUTS = {"vgg16": {"last_conv": 28, "last_block": 24}, "mobilenet_v2": {"last_conv": 18, "last_block": 17}}
WIDTH = {"vgg16": 512, "mobilenet_v2": 1280}
STEM_WIDTH = {"vgg16": {28: 512, 24: 512}, "mobilenet_v2": {18: 320, 17: 160}}


def backbone_features(name: str) -> nn.Sequential:
    """torchvision's randomly initialised ``features`` (VGG-16 without building its 120M-parameter classifier)."""
    from torchvision import models

    if name == "mobilenet_v2":
        return models.mobilenet_v2(weights=None).features
    features = models.vgg.make_layers(models.vgg.cfgs["D"])
    for m in features.modules():
        if isinstance(m, nn.Conv2d):  # as torchvision's VGG initialises its convolutions
            nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            nn.init.zeros_(m.bias)
    return features
