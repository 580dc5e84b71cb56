"""Ensembles and test-time options: one saved model of K seeds that predict, export and reload as one; mirrored
and cropped test views."""

from __future__ import annotations

import json

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.learn.checkpoint import read_checkpoint, restore
from deformsim.learn.crops import saliency_box
from deformsim.learn.data import load_image
from deformsim.learn.models import Ensemble, build, members
from deformsim.learn.onnx import to_onnx
from deformsim.learn.predict import load
from deformsim.learn.train import fit

pytestmark = pytest.mark.torch

CFG = dict(backbone="efficientnet_lite0", weights="offline", image_size=64, epochs=2, batch_size=16, head="linear")


@pytest.fixture(scope="module")
def ensemble_dir(blobs, tmp_path_factory):
    out = tmp_path_factory.mktemp("ensemble")
    fit(blobs, TrainConfig(**CFG, ensemble=3), out, progress=False)
    return out


def test_an_ensemble_predicts_the_mean_of_its_members(ensemble_dir, blobs, tmp_path):
    predictor = load(ensemble_dir)
    assert isinstance(predictor.model, Ensemble) and len(members(predictor.model)) == 3
    paths = list(blobs["path"][::8])
    x = torch.stack([load_image(p, 64) for p in paths])
    with torch.no_grad():
        each = torch.stack([net.predict(x) for net in members(predictor.model)])
    assert not torch.allclose(each[0], each[1])  # members differ by their seeds
    np.testing.assert_allclose(predictor.predict_proba(paths), each.mean(0).double().numpy(), atol=1e-6)
    # the first member is the single model of the same seed
    fit(blobs, TrainConfig(**CFG), tmp_path / "single", progress=False)
    np.testing.assert_allclose(load(tmp_path / "single").predict_proba(paths), each[0].double().numpy(), atol=1e-6)


def test_each_member_holds_out_its_own_fifth_and_the_ensemble_scores_out_of_bag(ensemble_dir, blobs):
    ckpt, _ = read_checkpoint(ensemble_dir)
    splits = ckpt["split"]["members"]
    assert len(splits) == 3 and ckpt["split"]["val"] == splits[0]["val"]  # member 0 splits as the single model
    for s in splits:
        assert not set(s["train"]) & set(s["val"]) and len(s["train"]) + len(s["val"]) == len(blobs)
    assert len({tuple(sorted(s["val"])) for s in splits}) == 3  # bagging: each member misses other images
    # out of bag: each held-out image scored by the mean of the members that held it out
    held = sorted(set().union(*(s["val"] for s in splits)))
    path = dict(zip(blobs["id"], blobs["path"]))
    y = dict(zip(blobs["id"], blobs["y"]))
    nets = members(load(ensemble_dir).model)
    with torch.no_grad():
        prob = {i: np.mean([float(net.predict(load_image(path[i], 64)[None])[0]) for net, s in zip(nets, splits)
                            if i in s["val"]]) for i in held}
    trained = json.loads((ensemble_dir / "train.json").read_text())
    got = trained["ensemble"]
    assert got["n_val"] == len(held) > len(splits[0]["val"])
    assert got["val_acc"] == pytest.approx(np.mean([(prob[i] >= 0.5) == y[i] for i in held]))
    # and each of those images' probability is recorded, for scores of a model trained on every image
    recorded = dict(zip(trained["held_out"]["ids"], trained["held_out"]["p_deformed"]))
    assert sorted(recorded) == held and all(recorded[i] == pytest.approx(prob[i], abs=1e-5) for i in held)


def test_an_ensemble_shares_one_stem_and_round_trips(ensemble_dir, blobs):
    ckpt, path = read_checkpoint(ensemble_dir)
    model, cfg = restore(ckpt, path)
    first, *rest = members(model)
    assert all(net.features[0] is first.features[0] for net in rest)  # one frozen stem: one feature cache
    assert cfg.ensemble == 3
    paths = list(blobs["path"][:6])
    np.testing.assert_array_equal(load(ensemble_dir).predict_proba(paths), load(ensemble_dir).predict_proba(paths))


@pytest.mark.parametrize("flip", [False, True])
def test_onnx_of_an_ensemble_agrees_with_torch(ensemble_dir, blobs, tmp_path, flip):
    model_dir = ensemble_dir
    if flip:  # the same weights with test-time flips on
        ckpt, _ = read_checkpoint(ensemble_dir)
        ckpt["config"]["tta_flip"] = True
        (tmp_path / "flip").mkdir()
        torch.save(ckpt, tmp_path / "flip" / "model.pt")
        model_dir = tmp_path / "flip"
    paths = list(blobs["path"][::10])
    expected = load(model_dir).predict_proba(paths)
    onnx_path = to_onnx(model_dir, tmp_path / "m.onnx")
    session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    got = session.run(["p_deformed"], {"image": torch.stack([load_image(p, 64) for p in paths]).numpy()})[0]
    np.testing.assert_allclose(got, expected, atol=1e-5)
    meta = {p.key: p.value for p in onnx.load(str(onnx_path)).metadata_props}
    assert meta["ensemble"] == "3" and meta["tta_flip"] == str(flip).lower()


def test_flips_average_the_image_and_its_mirror(ensemble_dir, blobs, tmp_path):
    ckpt, _ = read_checkpoint(ensemble_dir)
    ckpt["config"]["tta_flip"] = True
    torch.save(ckpt, tmp_path / "model.pt")
    paths = list(blobs["path"][::10])
    model = load(ensemble_dir).model
    with torch.no_grad():
        x = torch.stack([load_image(p, 64) for p in paths])
        mirrored = torch.stack([load_image(p, 64, flip=True) for p in paths])
        assert torch.equal(mirrored, x.flip(-1))
        expected = ((model.predict(x) + model.predict(mirrored)) / 2).double().numpy()
    np.testing.assert_allclose(load(tmp_path).predict_proba(paths), expected, atol=1e-6)


def test_saliency_crop_frames_the_object(tmp_path):
    rng = np.random.default_rng(0)
    image = np.clip(rng.normal(200, 4, (300, 400, 3)), 0, 255).astype(np.uint8)
    image[150:230, 250:330] = (30, 60, 200)  # an 80 px object off centre
    left, top, right, bottom = saliency_box(Image.fromarray(image))
    assert right - left == bottom - top  # square
    assert left <= 250 and top <= 150 and right >= 330 and bottom >= 230  # holds the object
    assert right - left <= 200  # and not much else
    assert 0 <= left and 0 <= top and right <= 400 and bottom <= 300


def test_a_cropped_model_reads_the_cropped_image(ensemble_dir, blobs, tmp_path):
    ckpt, _ = read_checkpoint(ensemble_dir)
    ckpt["config"]["crop"] = "saliency"
    torch.save(ckpt, tmp_path / "model.pt")
    image = np.full((160, 160, 3), 190, np.uint8)
    image[20:60, 100:140] = (200, 40, 40)  # a small part in a corner of the photo
    path = tmp_path / "photo.png"
    Image.fromarray(image).save(path)
    model = load(ensemble_dir).model
    with torch.no_grad():
        expected = model.predict(load_image(path, 64, crop="saliency")[None]).double().numpy()
        whole = model.predict(load_image(path, 64)[None]).double().numpy()
    got = load(tmp_path).predict_proba([path])
    np.testing.assert_allclose(got, expected, atol=1e-6)
    assert not np.allclose(got, whole, atol=1e-6)


def test_cli_trains_an_ensemble_that_evaluates_and_exports(blobs, tmp_path):
    from typer.testing import CliRunner

    from deformsim.cli.app import app

    cfg = tmp_path / "c.yaml"
    cfg.write_text("train: {image_size: 64, backbone: efficientnet_lite0, weights: offline, head: linear}\n")
    folder = blobs["path"][0].rsplit("/", 2)[0]
    run = CliRunner().invoke
    res = run(app, ["train", folder, "--out", str(tmp_path / "m"), "--epochs", "1", "--ensemble", "2", "--config",
                    str(cfg), "--no-progress"])
    assert res.exit_code == 0, res.output
    assert read_checkpoint(tmp_path / "m")[0]["config"]["ensemble"] == 2
    res = run(app, ["evaluate", str(tmp_path / "m"), "--real", folder])
    assert res.exit_code == 0, res.output
    res = run(app, ["export", str(tmp_path / "m"), "--onnx", str(tmp_path / "m.onnx")])
    assert res.exit_code == 0 and (tmp_path / "m.onnx").is_file()
    res = run(app, ["train", folder, "--out", str(tmp_path / "m2"), "--ensemble", "0", "--config", str(cfg)])
    assert res.exit_code == 2 and "train.ensemble" in res.output


def test_center_crop_is_the_largest_centred_square():
    from deformsim.learn.crops import crop

    image = Image.fromarray(np.arange(30 * 40 * 3, dtype=np.uint32).reshape(40, 30, 3).astype(np.uint8))
    out = crop(image, "center")
    assert out.size == (30, 30)
    np.testing.assert_array_equal(np.asarray(out), np.asarray(image)[5:35])


def test_pad_keeps_the_whole_image_unsqueezed_on_a_square():
    """A portrait photo is kept whole at its aspect (not squeezed by the resize to the square input); the margins are
    its own blurred colours, not one flat band; a square image passes unchanged."""
    from deformsim.learn.crops import crop

    rng = np.random.default_rng(0)
    image = Image.fromarray(rng.integers(0, 256, (40, 30, 3), dtype=np.uint8))
    out = np.asarray(crop(image, "pad"))
    assert out.shape == (40, 40, 3)
    np.testing.assert_array_equal(out[:, 5:35], np.asarray(image))
    assert out[:, :5].std(axis=(0, 1)).min() > 0
    square = Image.fromarray(rng.integers(0, 256, (32, 32, 3), dtype=np.uint8))
    np.testing.assert_array_equal(np.asarray(crop(square, "pad")), np.asarray(square))


def test_an_ensemble_of_certain_members_has_a_finite_loss():
    """A member's float32 sigmoid saturates at exactly 1: the ensemble's logit stays finite, so its loss does too."""
    first, second = (build(TrainConfig(**CFG, seed=s))[0] for s in (0, 1))
    for net in (first, second):
        torch.nn.init.constant_(net.head[-1].bias, 40.0)  # P(deformed) = 1 in float32
    model = Ensemble([first, second]).eval()
    with torch.no_grad():
        logits = model.tail(model.stem(torch.rand(2, 3, 64, 64)))
    assert torch.isfinite(logits).all()
    assert torch.isfinite(torch.nn.functional.binary_cross_entropy_with_logits(logits, torch.tensor([1.0, 0.0])))
