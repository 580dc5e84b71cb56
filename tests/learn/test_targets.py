"""Heads on the dense labels (train.target severity, family, localise): they learn, save, load and export."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from deformsim.config import TrainConfig
from deformsim.dataset.variants import variant_table
from deformsim.errors import UserError
from deformsim.learn.models import build
from deformsim.learn.predict import load
from deformsim.learn.targets import region_masks
from deformsim.learn.train import fit
from tests.learn.dense_blobs import FAMILIES, make_dense_dataset

pytestmark = pytest.mark.torch

CFG = dict(weights="offline", image_size=64, batch_size=16, epochs=15)


@pytest.fixture(scope="module")
def dense(tmp_path_factory) -> pd.DataFrame:
    root = make_dense_dataset(tmp_path_factory.mktemp("dense") / "data", 12)
    return variant_table(root, "black")


@pytest.fixture(scope="module")
def models(dense, tmp_path_factory):
    out = {}
    for target in ("severity", "family", "localise"):
        folder = tmp_path_factory.mktemp(target)
        out[target] = fit(dense, TrainConfig(**CFG, target=target), folder, progress=False), load(folder)
    return out


def _val(dense, predictor):
    return dense[dense["id"].isin(predictor.split["val"])].reset_index(drop=True)


def test_severity_beats_the_mean_and_predicts_mm(models, dense):
    result, predictor = models["severity"]
    assert predictor.target == "severity" and predictor.outputs == ["max_disp_mm"]
    val, train = _val(dense, predictor), dense[dense["id"].isin(predictor.split["train"])]
    mm = predictor.predict_outputs(list(val["path"]))
    truth = val["max_disp_mm"].to_numpy()
    mae = np.abs(mm - truth).mean()
    assert mae == pytest.approx(result.history[-1]["val_score"], rel=1e-4)
    assert result.history[-1]["metric"] == "mae_mm"
    assert mae < 0.6 * np.abs(truth - train["max_disp_mm"].mean()).mean()  # well below always answering the mean
    assert mm[truth > 0].mean() > mm[truth == 0].mean() + 3


def test_family_is_multilabel(models, dense):
    result, predictor = models["family"]
    assert predictor.outputs == list(FAMILIES)
    val = _val(dense, predictor)
    p = predictor.predict_outputs(list(val["path"]))
    assert p.shape == (len(val), 2) and ((p >= 0) & (p <= 1)).all()
    truth = val[[f"family_{f}" for f in FAMILIES]].to_numpy() == 1
    assert ((p >= 0.5) == truth).mean() >= 0.85
    assert result.history[-1]["val_score"] >= 0.8


def test_localise_finds_the_region_with_a_frozen_backbone(models, dense):
    result, predictor = models["localise"]
    val = _val(dense, predictor)
    maps = predictor.predict_outputs(list(val["path"]))
    assert maps.shape == (len(val), 16, 16)
    truth = region_masks(list(val["region"]), 16).numpy() >= 0.5
    pred = maps >= 0.5
    iou = (pred & truth).sum() / (pred | truth).sum()
    assert iou == pytest.approx(result.history[-1]["val_score"], abs=1e-6)
    assert iou > 0.3
    intact = (val["y"] == 0).to_numpy()
    assert pred[intact].mean() < 0.5 * pred[~intact].mean()  # few region pixels on intact parts
    saved = torch.load(result.model_path, weights_only=True)["state_dict"]
    initial = build(TrainConfig(**CFG, target="localise"))[0].state_dict()
    changed = {k for k in saved if not torch.equal(saved[k], initial[k])}
    assert changed and all(k.startswith("head.") for k in changed)


def test_label_models_and_predict_proba_are_kept_apart(models, dense):
    _, predictor = models["family"]
    with pytest.raises(UserError, match="predicts train.target family, not label"):
        predictor.predict_proba(list(dense["path"][:2]))


def test_localise_exports_region_maps_to_onnx(models, dense, tmp_path):
    import onnx
    import onnxruntime as ort

    from deformsim.learn.data import load_image
    from deformsim.learn.onnx import to_onnx

    result, predictor = models["localise"]
    paths = list(dense["path"][:3])
    path = to_onnx(result.model_path, tmp_path / "m.onnx")
    meta = {p.key: p.value for p in onnx.load(str(path)).metadata_props}
    assert meta["target"] == "localise" and meta["outputs"] == "region"
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    got = session.run(["p_region"], {"image": torch.stack([load_image(p, 64) for p in paths]).numpy()})[0]
    np.testing.assert_allclose(got, predictor.predict_outputs(paths), atol=1e-5)


def test_wrong_labels_for_a_target_stop_before_training(dense, tmp_path):
    plain = dense.drop(columns=["max_disp_mm"])
    with pytest.raises(UserError, match="no max_disp_mm column"):
        fit(plain, TrainConfig(**CFG, target="severity"), tmp_path, progress=False)
    with pytest.raises(UserError, match="family_<name>"):
        fit(dense.drop(columns=[f"family_{f}" for f in FAMILIES]), TrainConfig(**CFG, target="family"), tmp_path)
    gone = dense.assign(region=[str(tmp_path / "nope.png")] * len(dense))
    with pytest.raises(UserError, match="region mask.*nope.png"):
        fit(gone, TrainConfig(**CFG, target="localise"), tmp_path, progress=False)
    with pytest.raises(UserError, match="train.augment"):
        fit(dense, TrainConfig(**CFG, target="localise", augment=True), tmp_path, progress=False)
    with pytest.raises(UserError, match="train.random_conv"):
        fit(dense, TrainConfig(**CFG, target="severity", random_conv=0.5), tmp_path, progress=False)
    assert not list(tmp_path.iterdir())
