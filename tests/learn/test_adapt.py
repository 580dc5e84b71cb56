"""Training options that aim at transfer, and adaptation from unlabelled photos (whose labels are never read)."""

from __future__ import annotations

import json
import shutil

import pytest
import torch

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.adapt import pseudo_labels
from deformsim.learn.checkpoint import read_checkpoint, restore
from deformsim.learn.models import build
from deformsim.learn.predict import load
from deformsim.learn.train import fit
from tests.learn.blobs import make_blobs

pytestmark = pytest.mark.torch

NORM = TrainConfig(weights="offline", image_size=64, epochs=3, batch_size=16, feature_norm=True)


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """Unlabelled 'real' photos: other blobs (another seed), in class folders and flattened with neutral names."""
    root = tmp_path_factory.mktemp("photos")
    table = make_blobs(root / "sorted", 12, seed=5)
    flat = root / "flat"
    flat.mkdir()
    for k, p in enumerate(sorted(table["path"], key=lambda s: str(s).rsplit("/", 1)[-1])):
        shutil.copy(p, flat / f"img{k:03d}.png")
    return root / "sorted", flat


def test_finetune_depth_and_head_choose_what_trains():
    model, _ = build(TrainConfig(weights="none", image_size=64, finetune="last_block", head="linear"))
    trainable = {n.split(".")[1] for n, p in model.named_parameters() if p.requires_grad and n.startswith("features")}
    assert trainable == {"24", "26", "28"}  # conv5_1..conv5_3
    assert [m.out_features for m in model.head if isinstance(m, torch.nn.Linear)] == [1]


def test_feature_norm_statistics_are_those_of_the_training_images(blobs, tmp_path):
    result = fit(blobs, NORM, tmp_path / "m", progress=False)
    model, _ = restore(read_checkpoint(result.model_path)[0])
    assert isinstance(model.norm, torch.nn.BatchNorm1d)
    assert float(model.norm.running_var.mean()) > 0
    p = load(tmp_path / "m").predict_proba(list(blobs["path"]))
    assert ((p >= 0.5) == blobs["y"].to_numpy()).mean() > 0.8


def test_adabn_needs_no_labels_and_ignores_the_folder_layout(blobs, photos, tmp_path):
    sorted_dir, flat_dir = photos
    a = fit(blobs, NORM, tmp_path / "a", progress=False, adapt=sorted_dir)
    b = fit(blobs, NORM, tmp_path / "b", progress=False, adapt=flat_dir)  # no intact/ or deformed/ at all
    sa, sb = (read_checkpoint(r.model_path)[0]["state_dict"] for r in (a, b))
    assert torch.allclose(sa["norm.running_mean"], sb["norm.running_mean"], atol=1e-5)
    assert torch.allclose(sa["norm.running_var"], sb["norm.running_var"], rtol=1e-4)
    plain = read_checkpoint(fit(blobs, NORM, tmp_path / "c", progress=False).model_path)[0]["state_dict"]
    assert not torch.allclose(plain["norm.running_mean"], sa["norm.running_mean"])  # statistics moved to the photos
    info = json.loads((tmp_path / "b" / "train.json").read_text())["adapted"]
    assert info["images"] == 24 and info["method"] == "adabn" and info["folder"] == str(flat_dir)


def test_selftrain_runs_on_a_flat_folder(blobs, photos, tmp_path):
    cfg = NORM.model_copy(update={"adapt_method": "selftrain", "adapt_epochs": 1, "pseudo_confidence": 0.6})
    fit(blobs, cfg, tmp_path / "s", progress=False, adapt=photos[1])
    info = json.loads((tmp_path / "s" / "train.json").read_text())["adapted"]
    assert info["method"] == "selftrain" and info["pseudo_labels"]["deformed"] == info["pseudo_labels"]["intact"]


def test_pseudo_labels_are_balanced_and_sure():
    model, _ = build(TrainConfig(weights="none", image_size=32, feature_norm=True))
    stems = torch.randn(40, 512, 2, 2)
    rows, labels = pseudo_labels(model, stems, TrainConfig(pseudo_confidence=0.51, feature_norm=True))
    assert len(rows) == len(labels) and labels.sum() * 2 == len(labels)
    assert len(set(rows.tolist())) == len(rows)


def test_adapt_is_checked_before_training(blobs, tmp_path):
    with pytest.raises(UserError, match="feature_norm"):
        fit(blobs, NORM.model_copy(update={"feature_norm": False}), tmp_path / "x", adapt=tmp_path)
    with pytest.raises(UserError, match="not found"):
        fit(blobs, NORM, tmp_path / "x", adapt=tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="holds no images"):
        fit(blobs, NORM, tmp_path / "x", adapt=tmp_path / "empty")
    assert not (tmp_path / "x").exists()  # nothing was trained or written
