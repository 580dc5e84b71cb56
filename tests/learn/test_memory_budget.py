"""Images go through the frozen layers in passes that fit a memory budget, whatever the allowed ``image_size``: a
model saved with ``image_size: 1024`` predicts a folder in bounded memory, with the predictions of small passes."""

from __future__ import annotations

import os
import subprocess
import sys

import torch

from deformsim.config import TrainConfig
from deformsim.learn import checkpoint, features
from deformsim.learn.features import PASS_BUDGET, image_bytes, pass_size, run_stem
from deformsim.learn.models import build
from tests.util import ROOT

PEAK = """
import runpy, sys
sys.argv = ["deformsim", "predict", *sys.argv[1:]]
try:
    runpy.run_module("deformsim.cli", run_name="__main__")
finally:
    print("peak", [l.split()[1] for l in open("/proc/self/status") if l.startswith("VmHWM")][0], file=sys.stderr)
"""


def _model(tmp_path, size: int, backbone: str = "mobilenet_v2"):
    cfg = TrainConfig(backbone=backbone, weights="none", image_size=size, batch_size=32)
    model, _ = build(cfg, load_weights=False)
    checkpoint.save(tmp_path / "model.pt", model, cfg, "none", [], {})
    return model


def test_a_pass_holds_at_most_the_budget_and_small_images_keep_their_batch(tmp_path):
    model = _model(tmp_path, 1024, "vgg16")
    assert image_bytes(model, 1024) > PASS_BUDGET // 2  # VGG-16's first layers: 256 MiB per image at 1024 px
    assert pass_size(model, 1024, 32) == 1
    assert pass_size(model, 64, 32) == 32


def test_predict_at_1024_pixels_holds_a_bounded_peak(blobs, tmp_path):
    _model(tmp_path, 1024)
    photos = list(blobs["path"][:8])
    out = subprocess.run([sys.executable, "-c", PEAK, str(tmp_path), *photos, "--csv", str(tmp_path / "p.csv")],
                         cwd=ROOT, capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": f"{ROOT}:{ROOT / 'src'}", "OMP_NUM_THREADS": "2"})
    assert out.returncode == 0, out.stderr[-2000:]
    peak_mib = int(out.stderr.split("peak")[-1]) / 1024
    assert peak_mib < 1500, peak_mib  # 1.1 GB in one image per pass; all 8 images in one pass: 4 GB
    assert len((tmp_path / "p.csv").read_text().splitlines()) == 9


def test_passes_give_the_activations_of_one_batch(blobs, tmp_path, monkeypatch):
    model = _model(tmp_path, 96)
    model.eval()
    paths = list(blobs["path"][:6])
    whole = run_stem(model, paths, 96, batch_size=6)
    monkeypatch.setattr(features, "PASS_BUDGET", image_bytes(model, 96) * 2)  # two images per pass
    assert pass_size(model, 96, 6) == 2
    torch.testing.assert_close(run_stem(model, paths, 96, batch_size=6), whole, rtol=1e-5, atol=1e-5)


def test_training_without_the_cache_sends_its_batches_through_the_stem_in_passes(blobs, tmp_path, monkeypatch):
    from deformsim.learn.train import _Inputs

    model = _model(tmp_path, 64)
    monkeypatch.setattr(features, "PASS_BUDGET", image_bytes(model, 64) * 3)  # three images per pass
    cfg = TrainConfig(backbone="mobilenet_v2", weights="none", image_size=64, batch_size=8, augment=True)
    inputs = _Inputs(model, list(blobs["path"][:8]), cfg, torch.device("cpu"), progress=False)
    seen, stem = [], model.stem
    monkeypatch.setattr(model, "stem", lambda x: seen.append(len(x)) or stem(x))
    z = inputs(torch.arange(8), train=True)
    assert seen == [3, 3, 2] and z.shape[0] == 8


def test_the_pass_size_of_a_model_in_training_at_a_tiny_size(tmp_path):
    model = _model(tmp_path, 32)
    model.train()  # its batch norms would refuse one image of 1 x 1 activations while training
    assert pass_size(model, 32, 8) == 8
