"""torchvision's zoo and DINOv2: their files map onto the registry's ``features`` exactly (tested on random weights,
since the downloads need the internet), and without a download the error names the file and where it goes."""

from __future__ import annotations

import socket

import pytest
import torch
from torchvision import models

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn import vit
from deformsim.learn import weights as W
from deformsim.learn.backbones import BACKBONES
from deformsim.learn.models import build

pytestmark = pytest.mark.torch


def _reference(name: str):
    """torchvision's randomly initialised network and a function giving its pooled features (N, width)."""
    torch.manual_seed(0)
    if name == "resnet50":
        net = models.resnet50().eval()
        body = torch.nn.Sequential(*list(net.children())[:-2])
        return net, lambda x: body(x).mean((2, 3))
    if name == "convnext_tiny":
        net = models.convnext_tiny().eval()
        return net, lambda x: net.features(x).mean((2, 3))
    if name == "efficientnet_v2_s":
        net = models.efficientnet_v2_s().eval()
        return net, lambda x: net.features(x).mean((2, 3))
    net = models.vit_b_16().eval()

    def cls(x):
        tokens = net._process_input(x)
        tokens = torch.cat([net.class_token.expand(len(x), -1, -1), tokens], dim=1)
        return net.encoder(tokens)[:, 0]

    return net, cls


@pytest.mark.parametrize("name", ["resnet50", "convnext_tiny", "efficientnet_v2_s", "vit_b_16"])
def test_torchvision_files_load_strictly_and_give_the_same_features(name):
    bb = BACKBONES[name]
    net, pooled = _reference(name)
    features = bb.features().eval()
    features.load_state_dict(bb.from_download(net.state_dict()), strict=True)
    x = torch.rand(2, 3, 224, 224)
    with torch.no_grad():
        ours = features(x).mean((2, 3))
        torch.testing.assert_close(ours, pooled(x), rtol=1e-4, atol=1e-4)


def _official_dinov2_names(state: dict) -> dict:
    """Our DINOv2 state dict in the names of Meta's checkpoint (the inverse of :func:`vit.dinov2_state`)."""
    out = {"mask_token": torch.zeros(1, 384)}
    for key, value in state.items():
        index, _, rest = key.partition(".")
        if index == "0":
            out[rest.replace("proj.", "patch_embed.proj.")] = value
        elif int(index) == vit.DEPTH + 1:
            out[f"norm.{rest.rpartition('.')[2]}"] = value
        else:
            out[f"blocks.{int(index) - 1}.{rest}"] = value
    return out


def test_dinov2_checkpoint_names_map_onto_the_features():
    features = vit.dinov2_vits14_features()
    official = _official_dinov2_names(features.state_dict())
    assert {"cls_token", "pos_embed", "patch_embed.proj.weight", "blocks.11.ls2.gamma", "blocks.0.attn.qkv.weight",
            "norm.bias"} <= set(official)
    again = vit.dinov2_vits14_features()
    again.load_state_dict(vit.dinov2_state(official), strict=True)
    x = torch.rand(1, 3, 96, 96)
    with torch.no_grad():
        assert torch.equal(again(x), features.eval()(x))
    assert official["pos_embed"].shape == (1, 37 * 37 + 1, 384)


@pytest.mark.parametrize("size", [64, 128, 224])
def test_transformers_read_any_input_size(size):
    for name in ("vit_b_16", "dinov2_vits14"):
        model, _ = build(TrainConfig(backbone=name, weights="none", image_size=size, head="linear"))
        with torch.no_grad():
            assert model.proba(torch.rand(2, 3, size, size)).shape == (2,)


def test_a_transformer_cannot_localise():
    with pytest.raises(ValueError, match="localise needs a convolutional backbone; vit_b_16 outputs tokens"):
        TrainConfig(backbone="vit_b_16", target="localise")


@pytest.mark.parametrize("name", ["resnet50", "dinov2_vits14"])
def test_without_the_download_one_line_names_the_file_and_the_folder(name, tmp_path, monkeypatch):
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "hub"))

    def unreachable(*args, **kwargs):
        raise OSError("network is unreachable")

    monkeypatch.setattr(socket, "create_connection", unreachable)
    with pytest.raises(UserError) as err:
        W.resolve(name, "imagenet")
    line = str(err.value)
    file = {"resnet50": "resnet50-11ad3fa6.pth", "dinov2_vits14": "dinov2_vits14_pretrain.pth"}[name]
    assert "\n" not in line and line.startswith(f"no pretrained weights for {name}: https://")
    assert file in line and str(tmp_path / "hub" / "checkpoints") in line and line.endswith("train.weights: none")
    with pytest.raises(UserError, match=f"no pretrained weights for {name}: there is no offline package"):
        W.resolve(name, "offline")


def test_a_downloaded_file_in_the_hub_cache_is_used(tmp_path, monkeypatch):
    """A file put into torch.hub's checkpoints folder by hand (an offline machine) loads, converted."""
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path))
    torch.manual_seed(1)
    source = vit.dinov2_vits14_features()
    (tmp_path / "checkpoints").mkdir()
    torch.save(_official_dinov2_names(source.state_dict()), tmp_path / "checkpoints" / "dinov2_vits14_pretrain.pth")
    state, desc = W.resolve("dinov2_vits14", "imagenet")
    assert desc == "torch.hub dinov2_vits14_pretrain.pth"
    assert torch.equal(state["0.pos_embed"], source.state_dict()["0.pos_embed"])


def test_a_corrupt_torchvision_file_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path))
    (tmp_path / "checkpoints").mkdir()
    (tmp_path / "checkpoints" / "resnet50-11ad3fa6.pth").write_bytes(b"not the weights")
    with pytest.raises(UserError, match="resnet50-11ad3fa6.pth are corrupt"):
        W.resolve("resnet50", "imagenet")
