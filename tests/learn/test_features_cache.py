"""The per-image cache of frozen-stem activations: only new images run the stem, cached predictions match."""

from __future__ import annotations

import pytest
import torch

from deformsim.config import TrainConfig
from deformsim.learn import features as F
from deformsim.learn.models import build
from deformsim.learn.predict import load
from deformsim.learn.train import fit

pytestmark = pytest.mark.torch

CFG = TrainConfig(weights="offline", image_size=64, epochs=1, batch_size=8)


@pytest.fixture
def counted(monkeypatch, tmp_path):
    """A fresh cache folder; the list of how many images each run of the frozen stem computed."""
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path / "cache"))
    calls: list[int] = []
    real = F.run_stem
    monkeypatch.setattr(F, "run_stem", lambda model, paths, *a, **k: calls.append(len(paths)) or real(model, paths, *a, **k))
    return calls


def test_superset_computes_only_new_images(blobs, counted):
    model, _ = build(CFG)
    paths = list(blobs["path"][:6])
    first = F.cached_stem(model, paths[:4], 64, 8)
    assert counted == [4] and first.dtype == torch.float32
    both = F.cached_stem(model, paths[2:] + paths[:2], 64, 8)  # 2 cached, 2 new, 2 cached
    assert counted == [4, 2]
    assert torch.equal(both[4:], first[:2]) and torch.equal(both[:2], first[2:4])
    exact = F.run_stem(model, paths[4:], 64, 8)
    assert torch.allclose(both[2:4], exact, rtol=1e-5, atol=1e-5)
    assert torch.equal(F.cached_stem(model, paths, 64, 8), torch.cat([first, both[2:4]]))
    assert counted == [4, 2, 2]  # the last call read everything from the cache


def test_other_weights_or_size_miss_and_corrupt_files_are_recomputed(blobs, counted):
    model, _ = build(CFG)
    paths = list(blobs["path"][:2])
    F.cached_stem(model, paths, 64, 8)
    F.cached_stem(model, paths, 96, 8)
    other, _ = build(CFG.model_copy(update={"weights": "none"}))
    F.cached_stem(other, paths, 64, 8)
    assert counted == [2, 2, 2]
    with torch.no_grad():
        model.features[0].weight.mul_(2)  # changed frozen weights: a new stem hash
    F.cached_stem(model, paths, 64, 8)
    assert counted == [2, 2, 2, 2]
    broken = F.cache_dir() / "features" / F.cache_key(model, paths, 64)[0]
    broken.write_bytes(b"not a tensor")
    F.cached_stem(model, paths, 64, 8)
    assert counted[-1] == 1


def test_cached_predictions_equal_uncached(blobs, counted, tmp_path):
    train = blobs.groupby("y").head(8)
    fit(train, CFG, tmp_path / "model", progress=False)
    assert counted == [16]
    predictor = load(tmp_path / "model")
    test = list(blobs.groupby("y").tail(3)["path"])
    p = predictor.predict_proba(list(train["path"]) + test)
    f = predictor.features(test, "pooled")
    assert counted == [16, 6]  # training images come from the cache; only the new ones run the stem
    predictor.cfg = predictor.cfg.model_copy(update={"cache_features": False})
    exact = predictor.predict_proba(list(train["path"]) + test)
    assert p == pytest.approx(exact, abs=1e-5)
    assert f == pytest.approx(predictor.features(test, "pooled"), rel=1e-4, abs=1e-5)
    assert counted == [16, 6]


@pytest.mark.parametrize("entry", [torch.zeros(3), torch.zeros(1, 2, 2, dtype=torch.float64), "not a tensor"])
def test_an_entry_of_the_wrong_shape_or_kind_is_computed_again_and_replaced(blobs, counted, entry):
    model, _ = build(CFG)
    paths = list(blobs["path"][:3])
    good = F.cached_stem(model, paths, 64, 8)
    broken = F.cache_dir() / "features" / F.cache_key(model, paths, 64)[1]
    torch.save(entry, broken)
    again = F.cached_stem(model, paths, 64, 8)
    assert counted == [3, 1] and (again - good).abs().max() < 1e-3, (again - good).abs().max()
    assert torch.equal(torch.load(broken, weights_only=True), again[1])  # replaced: the next run reads it
    assert torch.equal(F.cached_stem(model, paths, 64, 8), again) and counted == [3, 1]


def test_grey_models_judge_brightness_only_and_cache_apart(blobs, counted, tmp_path):
    """With train.grey an image and its grey copy get the same prediction, after saving and loading too (an ensemble
    here); its stem activations are cached apart from the colour model's."""
    train = blobs.groupby("y").head(8)
    cfg = CFG.model_copy(update={"grey": True, "ensemble": 2})
    fit(train, cfg, tmp_path / "model", progress=False)
    predictor = load(tmp_path / "model")
    assert predictor.cfg.grey
    x = torch.rand(2, 3, 64, 64)
    grey = (x * torch.tensor([0.2126, 0.7152, 0.0722]).view(1, 3, 1, 1)).sum(1, keepdim=True).expand_as(x)
    net = predictor.model
    with torch.no_grad():
        assert torch.allclose(net.predict(x), net.predict(grey), atol=1e-6)
        colour, _ = build(CFG)
        assert not torch.allclose(colour.stem(x), colour.stem(grey), atol=1e-3)
    assert F.cache_key(net, list(train["path"][:1]), 64) != F.cache_key(colour, list(train["path"][:1]), 64)
