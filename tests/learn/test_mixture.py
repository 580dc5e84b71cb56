"""Models of several backbones (``train.ensemble_backbones``): one saved model whose prediction, ONNX graph and
Grad-CAM are the mean of its backbones' models, checked as one file, and fine-tuned as one."""

from __future__ import annotations

import json

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch
from pydantic import ValidationError

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.identity import file_digest
from deformsim.learn.checkpoint import read_checkpoint
from deformsim.learn.data import load_image
from deformsim.learn.finetune import Recipe, finetune
from deformsim.learn.onnx import to_onnx
from deformsim.learn.predict import load
from deformsim.learn.train import fit
from tests.learn.blobs import make_blobs

pytestmark = pytest.mark.torch

CFG = dict(weights="offline", image_size=64, epochs=2, batch_size=16, head="linear")


@pytest.fixture(scope="module")
def mixture_dir(blobs, tmp_path_factory):
    out = tmp_path_factory.mktemp("mixture")
    fit(blobs, TrainConfig(**CFG, backbone="efficientnet_lite0", ensemble_backbones=["mobilenet_v2"]), out,
        progress=False)
    return out


def test_a_mixture_predicts_the_mean_of_its_backbones_models(mixture_dir, blobs, tmp_path):
    ckpt, _ = read_checkpoint(mixture_dir)
    val = blobs[blobs["id"].isin(ckpt["split"]["val"])]  # both backbones' models held out the same images
    paths = list(val["path"])
    singles = []
    for backbone in ("efficientnet_lite0", "mobilenet_v2"):
        fit(blobs, TrainConfig(**CFG, backbone=backbone), tmp_path / backbone, progress=False)
        singles.append(load(tmp_path / backbone).predict_proba(paths))
    assert not np.allclose(singles[0], singles[1])
    mean = np.mean(singles, axis=0)
    np.testing.assert_allclose(load(mixture_dir).predict_proba(paths), mean, atol=1e-6)
    info = json.loads((mixture_dir / "train.json").read_text())
    assert [m["backbone"] for m in info["mixture"]] == ["mobilenet_v2"]
    assert "mobilenet_v2" in info["mixture"][0]["weights"]
    assert info["mixture_validation"] == {"backbones": 2, "n_val": len(val),
                                          "val_acc": pytest.approx(np.mean((mean >= 0.5) == val["y"].to_numpy()))}


def test_the_backbones_caches_fill_from_one_decoding_of_each_image(blobs, tmp_path, monkeypatch):
    import deformsim.learn.data as data
    from deformsim.learn.features import cached_stem, run_stem
    from deformsim.learn.models import build

    decoded = []
    load = data.load_image
    monkeypatch.setattr(data, "load_image", lambda path, *a, **k: decoded.append(path) or load(path, *a, **k))
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path / "cache"))  # nothing cached yet
    cfg = TrainConfig(**{**CFG, "epochs": 1}, backbone="efficientnet_lite0", ensemble_backbones=["mobilenet_v2"])
    fit(blobs, cfg, tmp_path / "m", progress=False)
    assert sorted(decoded) == sorted(blobs["path"])
    paths = list(blobs["path"][:8])
    for backbone in ("efficientnet_lite0", "mobilenet_v2"):
        model, _ = build(TrainConfig(**CFG, backbone=backbone))
        decoded.clear()
        cached = cached_stem(model, paths, 64, 16)
        assert not decoded  # every image was in the cache
        torch.testing.assert_close(cached, run_stem(model, paths, 64, 16), rtol=0, atol=1e-5)


def test_onnx_of_a_mixture_agrees_with_torch(mixture_dir, blobs, tmp_path):
    paths = list(blobs["path"][::10])
    onnx_path = to_onnx(mixture_dir, tmp_path / "m.onnx")
    session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    got = session.run(["p_deformed"], {"image": torch.stack([load_image(p, 64) for p in paths]).numpy()})[0]
    np.testing.assert_allclose(got, load(mixture_dir).predict_proba(paths), atol=1e-5)
    meta = {p.key: p.value for p in onnx.load(str(onnx_path)).metadata_props}
    assert meta["backbone"] == "efficientnet_lite0+mobilenet_v2"


def test_a_mixtures_gradcam_averages_its_backbones_maps(mixture_dir, blobs):
    mixture, first = load(mixture_dir), load(mixture_dir)
    first.others = []  # the first backbone's model alone
    paths = list(blobs[blobs["y"] == 1]["path"][:4])  # deformed: maps with evidence in them
    maps, alone = mixture.gradcam(paths), [first.gradcam(paths), mixture.others[0].gradcam(paths)]
    side = max(m.shape[-1] for m in alone)
    assert maps.shape == (4, side, side) and maps.min() >= 0 and maps.max() <= 1
    np.testing.assert_allclose(maps, np.mean(alone, axis=0), atol=1e-6)  # both 2 x 2 at 64 px


def _doctored(mixture_dir, tmp_path, change) -> str:
    ckpt, _ = read_checkpoint(mixture_dir)
    change(ckpt)
    (tmp_path / "bad").mkdir(parents=True)
    torch.save(ckpt, tmp_path / "bad" / "model.pt")
    with pytest.raises(UserError) as exc:
        load(tmp_path / "bad")
    return str(exc.value)


def test_a_doctored_mixture_is_one_line_naming_its_model(mixture_dir, tmp_path):
    def nan(ckpt):
        tensor = next(v for v in ckpt["mixture"][0]["state_dict"].values() if v.is_floating_point())
        tensor.fill_(float("nan"))

    assert "(mixture model 1) holds non-finite weights" in _doctored(mixture_dir, tmp_path / "a", nan)
    assert "trained otherwise than the first" in _doctored(
        mixture_dir, tmp_path / "b", lambda c: c["mixture"][0]["config"].update(image_size=96))
    assert "holds other backbones than its train.ensemble_backbones (mobilenet_v2)" in _doctored(
        mixture_dir, tmp_path / "c", lambda c: c.pop("mixture"))


def test_backbones_named_twice_or_off_label_are_config_errors():
    with pytest.raises(ValidationError, match=r"names train.backbone \(vgg16\) again"):
        TrainConfig(ensemble_backbones=["vgg16"])
    with pytest.raises(ValidationError, match="names mobilenet_v2 twice"):
        TrainConfig(ensemble_backbones=["mobilenet_v2", "mobilenet_v2"])
    with pytest.raises(ValidationError, match="applies to train.target label, not severity"):
        TrainConfig(ensemble_backbones=["mobilenet_v2"], target="severity")


def test_fine_tuning_a_mixture_adapts_every_backbones_model(mixture_dir, tmp_path):
    table = make_blobs(tmp_path / "real", 6, seed=11)
    result = finetune(mixture_dir, tmp_path / "real", tmp_path / "ft", Recipe(part="head", steps=20, lr=1e-2, views=1),
                      progress=False)
    before, after = read_checkpoint(mixture_dir)[0], read_checkpoint(result.model_path)[0]
    for old, new in ((before, after), (before["mixture"][0], after["mixture"][0])):
        changed = {k.split(".")[0] for k in old["state_dict"] if not torch.equal(old["state_dict"][k], new["state_dict"][k])}
        assert changed == {"head"}
    assert after["adapted_on"] == sorted(file_digest(p) for p in table["path"])
    assert [m.backbone for m in (load(result.model_path).model, *(o.model for o in load(result.model_path).others))] \
        == ["efficientnet_lite0", "mobilenet_v2"]
