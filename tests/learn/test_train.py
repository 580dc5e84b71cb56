"""Training: the model's frozen/trainable split, learning an easy task, the feature cache, determinism."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from deformsim.config import TrainConfig
from deformsim.dataset.tables import split
from deformsim.errors import UserError
from deformsim.learn import features as F
from deformsim.learn.models import build
from deformsim.learn.predict import load
from deformsim.learn.train import fit
from deformsim.learn.train_file import read_train

pytestmark = pytest.mark.torch

CFG = TrainConfig(weights="offline", image_size=64, epochs=3, batch_size=16)


@pytest.fixture(scope="module")
def trained(blobs, tmp_path_factory):
    out = tmp_path_factory.mktemp("model")
    return fit(blobs, CFG, out, progress=False), out


def test_model_layout():
    model, _ = build(TrainConfig(weights="none", image_size=64))
    trainable = {n for n, p in model.named_parameters() if p.requires_grad}
    assert trainable == {"features.28.weight", "features.28.bias"} | {n for n, _ in model.head.named_parameters(prefix="head")}
    assert [m.out_features for m in model.head if isinstance(m, torch.nn.Linear)] == [256, 128, 1]
    p = model.eval().proba(torch.rand(2, 3, 64, 64))
    assert p.shape == (2,) and ((p > 0) & (p < 1)).all()


def test_head_only_model_learns_on_the_whole_frozen_network(blobs, tmp_path):
    """train.finetune none: the whole backbone is cached once and only the head learns (the fast option)."""
    from deformsim.learn.gradcam import gradcam

    cfg = CFG.model_copy(update={"finetune": "none"})
    model, _ = build(cfg)
    assert model.cut == len(model.features)
    head = {n for n, _ in model.head.named_parameters(prefix="head")}
    assert {n for n, p in model.named_parameters() if p.requires_grad} == head
    result = fit(blobs, cfg, tmp_path / "m", progress=False)
    assert result.history[-1]["val_acc"] >= 0.75  # chance is 0.5
    net = load(tmp_path / "m").model
    stems = net.stem(torch.rand(3, 3, 64, 64))
    assert stems.shape == (3, 512, 2, 2)  # VGG-16's pooled last map at 64 px: nothing left to run but the head
    cams = gradcam(net, stems)
    assert cams.shape == (3, 2, 2) and np.isfinite(cams).all() and cams.max() <= 1


def test_bfloat16_steps_learn_and_keep_a_float32_model(blobs, tmp_path):
    """train.precision bfloat16 (auto's choice on a CPU with AVX-512 BF16): the steps' passes run in bfloat16, the
    model still learns the easy task, and the weights it saves (and predicts with) stay float32."""
    result = fit(blobs, CFG.model_copy(update={"precision": "bfloat16"}), tmp_path / "m", progress=False)
    assert result.history[-1]["val_acc"] >= 0.85  # chance is 0.5
    predictor = load(tmp_path / "m")
    assert {t.dtype for t in predictor.model.state_dict().values() if t.is_floating_point()} == {torch.float32}


@pytest.mark.parametrize("native", [False, True])
def test_auto_precision_is_bfloat16_only_where_the_cpu_computes_it(native, monkeypatch):
    """Elsewhere torch emulates bfloat16, slower than float32: auto must not slow such a CPU down."""
    from deformsim.learn.device import native_bfloat16, step_autocast

    monkeypatch.setattr(torch.cpu, "_is_avx512_bf16_supported", lambda: native)
    monkeypatch.setattr(torch.cpu, "_is_amx_tile_supported", lambda: False)
    native_bfloat16.cache_clear()
    try:
        formats = {}
        for precision in ("auto", "float32", "bfloat16"):
            with step_autocast(precision, torch.device("cpu")):
                formats[precision] = torch.nn.functional.linear(torch.ones(2, 3), torch.ones(4, 3)).dtype
    finally:
        native_bfloat16.cache_clear()
    assert formats == {"auto": torch.bfloat16 if native else torch.float32, "float32": torch.float32,
                       "bfloat16": torch.bfloat16}


def test_mobilenet_model_trains_last_block_only():
    model, desc = build(TrainConfig(backbone="mobilenet_v2", weights="offline", image_size=64))
    assert "mobilenet_v2-b0353104.pth" in desc
    trainable = {n.split(".")[1] for n, p in model.named_parameters() if p.requires_grad and n.startswith("features")}
    assert trainable == {"18"}
    model.train()
    assert not model.features[0][1].training and model.features[18][1].training  # frozen BatchNorm stays in eval


def test_learns_easy_task_on_held_out_split(trained, blobs):
    result, out = trained
    assert result.model_path == out / "model.pt" and (out / "train.json").is_file()
    assert [h["epoch"] for h in result.history] == [1, 2, 3]
    assert result.history[-1]["val_acc"] >= 0.85  # chance is 0.5
    predictor = load(out)
    val = blobs[blobs["id"].isin(predictor.split["val"])]
    assert len(val) == 16 and set(val["y"]) == {0, 1}
    assert not set(predictor.split["val"]) & set(predictor.split["train"])
    acc = ((predictor.predict_proba(list(val["path"])) >= 0.5) == val["y"].to_numpy()).mean()
    assert acc == pytest.approx(result.history[-1]["val_acc"], abs=1 / 16)


def test_train_json_is_what_fit_returns_with_a_version_and_reads_back(trained):
    result, out = trained
    written = json.loads((out / "train.json").read_text())
    assert written["schema_version"] == 1 and set(written) == {  # the keys version 0.2.0 wrote, and the version
        "weights", "seconds", "history", "n_train", "n_val", "adapted", "ensemble", "held_out", "config", "schema_version"}
    back = read_train(out)
    assert back == result.record and back.dump() == written
    assert back.history[-1].scores() == ("acc", result.history[-1]["acc"], result.history[-1]["val_acc"])
    assert back.held_out.ids == written["held_out"]["ids"] and back.config == CFG.model_dump(mode="json")


def test_an_older_train_json_reads_and_a_newer_or_foreign_one_is_refused_in_one_line(trained, tmp_path):
    _, out = trained
    old = {k: v for k, v in json.loads((out / "train.json").read_text()).items() if k != "schema_version"}
    path = tmp_path / "train.json"
    path.write_text(json.dumps(old))
    assert read_train(tmp_path).schema_version == 1
    for content, said in (({**old, "schema_version": 3}, f"{path} has schema_version 3, newer than this deformsim reads"),
                          ({**old, "n_val": "4"}, f"{path} is not a deformsim training record (train.json): n_val: "
                                                  "Input should be a valid integer (got 4)")):
        path.write_text(json.dumps(content))
        with pytest.raises(UserError) as err:
            read_train(path)
        assert str(err.value).startswith(said) and "\n" not in str(err.value)


def test_only_last_conv_and_head_change(trained):
    result, _ = trained
    saved = torch.load(result.model_path, weights_only=True)["state_dict"]
    initial, _ = build(CFG)  # same seed: the same starting point
    before = initial.state_dict()
    for name, value in saved.items():
        frozen = name.startswith("features.") and int(name.split(".")[1]) < 28
        if frozen or name in ("mean", "std"):
            assert torch.equal(value, before[name]), name
        else:
            assert not torch.equal(value, before[name]), name


def test_training_is_deterministic_and_reuses_cache(trained, blobs, tmp_path, monkeypatch):
    computed = []
    real = F.run_stem
    monkeypatch.setattr(F, "run_stem", lambda *a, **k: computed.append(1) or real(*a, **k))
    again = fit(blobs, CFG, tmp_path, progress=False)
    assert computed == []  # cache hit: the frozen layers did not run
    strip = lambda h: [{k: v for k, v in row.items() if k != "seconds"} for row in h]  # noqa: E731
    assert strip(again.history) == strip(trained[0].history)


def test_cache_key_tracks_images_and_weights(blobs, tmp_path):
    model, _ = build(TrainConfig(weights="none", image_size=64))
    paths = [shutil.copy(p, tmp_path) for p in blobs["path"][:4]]
    key = F.cache_key(model, paths, 64)
    assert F.cache_key(model, paths, 96) != key
    st = os.stat(paths[0])
    os.utime(paths[0], ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))  # touched: the same image
    assert F.cache_key(model, paths, 64) == key
    Path(paths[0]).write_bytes(Path(blobs["path"][5]).read_bytes())  # the image was rewritten
    assert F.cache_key(model, paths, 64) != key
    other, _ = build(TrainConfig(weights="none", image_size=64, seed=1))
    assert F.cache_key(other, paths, 64) != F.cache_key(model, paths, 64)


def test_the_stem_runs_channels_last_and_caches_apart_from_the_default_layout(blobs, monkeypatch):
    import dataclasses

    from deformsim.learn import backbones
    from deformsim.learn.data import load_image

    model, _ = build(TrainConfig(weights="offline", image_size=64))
    model.eval()
    x = torch.stack([load_image(p, 64) for p in blobs["path"][:4]])
    with torch.no_grad():
        fast = model.stem(x)
        plain = model.features[: model.cut]((x - model.mean) / model.std)
    assert fast.is_contiguous()  # what is cached, and what the trainable layers read, keeps the default layout
    torch.testing.assert_close(fast, plain, rtol=1e-4, atol=1e-3)  # rounded otherwise: up to 8e-4 on values up to 200
    key = F.cache_key(model, list(blobs["path"][:1]), 64)
    off = dataclasses.replace(backbones.BACKBONES["vgg16"], channels_last=False)
    monkeypatch.setitem(backbones.BACKBONES, "vgg16", off)
    F._STEM_HASHES.clear()
    assert F.cache_key(model, list(blobs["path"][:1]), 64) != key  # no file of one layout is read for the other


def test_uncached_and_augmented_training_run(blobs, tmp_path):
    small = blobs.groupby("y").head(6)
    for cfg in (CFG.model_copy(update={"cache_features": False, "epochs": 1}),
                CFG.model_copy(update={"augment": True, "epochs": 1}),
                CFG.model_copy(update={"random_conv": 0.5, "augment": True, "epochs": 1})):
        result = fit(small, cfg, tmp_path, progress=False)
        assert np.isfinite(result.history[0]["loss"])


def test_split_keeps_objects_together():
    table = pd.DataFrame({"sample": np.repeat(np.arange(20), 4), "y": np.repeat(np.arange(20) % 2, 4)})
    tr, va = split(table, 0.8, seed=3)
    assert len(tr) == 64 and len(va) == 16
    assert not set(table["sample"][tr]) & set(table["sample"][va])
    assert table["y"][va].sum() == 8
    assert (split(table, 0.8, seed=3)[1] == va).all() and not (split(table, 0.8, seed=4)[1] == va).all()


def test_bad_table_is_rejected_before_work(tmp_path):
    with pytest.raises(UserError, match="missing"):
        fit(pd.DataFrame({"id": ["a", "b"], "path": [str(tmp_path / "nope.png")] * 2, "y": [0, 1]}), CFG, tmp_path)
    with pytest.raises(UserError, match="empty"):
        fit(pd.DataFrame({"id": [], "path": [], "y": []}), CFG, tmp_path)


def test_a_model_write_that_torch_fails_is_a_resource_error(blobs, tmp_path, monkeypatch):
    from deformsim.errors import ResourceError
    from deformsim.learn import checkpoint

    real = torch.save

    def full(obj, f, *args, **kwargs):  # the model's file: what torch.save raises when the disk fills
        if not Path(getattr(f, "name", f)).name.startswith(".model."):
            return real(obj, f, *args, **kwargs)
        raise RuntimeError("[enforce fail at inline_container.cc:672] . unexpected pos 576 vs 534")

    monkeypatch.setattr(checkpoint.torch, "save", full)
    with pytest.raises(ResourceError, match="cannot write .*model.pt .*unexpected pos.*disk full"):
        fit(blobs.groupby("y").head(4), CFG.model_copy(update={"epochs": 1}), tmp_path / "m", progress=False)
    assert not list((tmp_path / "m").iterdir())  # no partial file left


def test_epochs_are_logged_at_debug_and_each_training_in_one_info_line(blobs, tmp_path, capsys):
    from deformsim.log import set_verbosity

    small = blobs.groupby("y").head(6)
    cfg = CFG.model_copy(update={"epochs": 2})
    try:
        fit(small, cfg, tmp_path / "normal", progress=False)
        normal = capsys.readouterr().err.splitlines()
        set_verbosity("verbose")
        fit(small, cfg, tmp_path / "verbose", progress=False)
        verbose = capsys.readouterr().err.splitlines()
    finally:
        set_verbosity("normal")
    summary = [line for line in normal if re.search(r" INFO trained 2 epochs \((bfloat16|float32)\) on ", line)]
    assert len(summary) == 1 and "validation accuracy" in summary[0] and not any("epoch 1/2" in x for x in normal)
    epochs = [line for line in verbose if " DEBUG epoch " in line]
    assert len(epochs) == 2 and all("validation accuracy" in line for line in epochs)


def test_a_training_without_validation_images_says_none(blobs, tmp_path, capsys):
    one_object_each = blobs.groupby("y").head(6).assign(sample=lambda t: t["y"])  # nothing left to validate on
    fit(one_object_each, CFG, tmp_path / "m", progress=False)
    summary = [line for line in capsys.readouterr().err.splitlines() if " INFO trained " in line]
    assert len(summary) == 1 and "validation" not in summary[0] and "(0 images)" not in summary[0]


def test_balance_weighs_the_fewer_deformed_images_up(blobs, tmp_path):
    # classes that overlap, as deformed images whose damage hardly shows do: of the jagged shapes only one in four is
    # labelled deformed, so an unbalanced model rates them about 0.25 and a balanced one near its class weight's odds
    table = blobs.assign(y=np.where(blobs["y"].to_numpy() == 1, np.arange(len(blobs)) % 4 == 0, 0).astype(int))
    jagged = blobs["y"].to_numpy() == 1
    probs = {}
    for balance in (False, True):
        fit(table, CFG.model_copy(update={"balance": balance}), tmp_path / str(balance), progress=False)
        probs[balance] = load(tmp_path / str(balance)).predict_proba(list(blobs["path"]))[jagged].mean()
    assert probs[False] < 0.45 < probs[True]
    with pytest.raises(ValueError, match="train.balance applies to train.target label"):
        TrainConfig(balance=True, target="severity")


def test_a_model_that_learned_nothing_is_a_warning_naming_the_rate(blobs, tmp_path, caplog):
    # a whole VGG block at the highest rate: its ReLUs die and it scores at most the share of one class (in float32:
    # where a diverged run's last epoch lands is chance, and this run's is known)
    diverged = CFG.model_copy(update={"lr": 10.0, "finetune": "last_block", "precision": "float32"})
    fit(blobs, diverged, tmp_path / "m", progress=False)
    (warning,) = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert re.match(r"training did not learn: after 3 epochs the model scores its training images (0\.[0-4]\d\d|0\.500), no "
                    r"better than calling them all one class \(0\.500\)", warning), warning
    assert "lower train.lr (now 10;" in warning
    caplog.clear()
    fit(blobs, CFG, tmp_path / "ok", progress=False)  # the same images at the default rate: learned, no warning
    assert not [r for r in caplog.records if r.levelname == "WARNING"]
