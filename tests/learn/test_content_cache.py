"""The feature cache keys on image content; prediction shows its progress."""

from __future__ import annotations

import os
import shutil
import sys

import numpy as np
import pytest
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.learn import features as F
from deformsim.learn.predict import load
from deformsim.learn.train import fit

pytestmark = pytest.mark.torch

CFG = TrainConfig(weights="offline", image_size=64, epochs=1, batch_size=8, lr=1e-4)


@pytest.fixture(scope="module")
def model_dir(blobs, tmp_path_factory):
    out = tmp_path_factory.mktemp("model")
    fit(blobs.groupby("y").head(10), CFG, out, progress=False)
    return out


def test_an_image_copied_over_another_with_the_same_size_and_time_is_not_served_from_the_cache(
        model_dir, blobs, tmp_path):
    a, b = tmp_path / "A.bmp", tmp_path / "B.bmp"  # BMPs of one size have one file size
    Image.open(blobs.path.iloc[-1]).convert("RGB").save(a)  # a deformed blob
    Image.open(blobs.path.iloc[0]).convert("RGB").save(b)  # an intact blob
    assert a.stat().st_size == b.stat().st_size
    t = a.stat().st_mtime_ns
    os.utime(b, ns=(t, t))
    predictor = load(model_dir)
    pa, pb = predictor.predict_proba([a, b])
    assert abs(pa - pb) > 1e-4
    shutil.copyfile(b, a)  # cp -p B.bmp A.bmp
    shutil.copystat(b, a)
    assert (a.stat().st_size, a.stat().st_mtime_ns) == (b.stat().st_size, t)
    again = load(model_dir).predict_proba([a])[0]
    assert again == pytest.approx(pb, abs=1e-6) and abs(again - pa) > 1e-4


def test_identical_images_share_one_cache_file(model_dir, blobs, tmp_path):
    model = load(model_dir).model
    shutil.copy(blobs.path.iloc[3], tmp_path / "copy.png")
    keys = F.cache_key(model, [blobs.path.iloc[3], str(tmp_path / "copy.png"), blobs.path.iloc[4]], 64)
    assert keys[0] == keys[1] != keys[2]


def test_prediction_shows_progress_on_a_terminal(model_dir, blobs, monkeypatch, tmp_path):
    bars = []
    real_bar = F.progress_bar
    monkeypatch.setattr(F, "progress_bar", lambda total, desc, enabled=True: bars.append((desc, enabled))
                        or real_bar(total, desc, False))
    paths = []
    for i in range(4):  # new images, so the frozen layers run
        arr = np.random.default_rng(i).integers(0, 255, (64, 64, 3), dtype=np.uint8)
        Image.fromarray(arr).save(tmp_path / f"{i}.png")
        paths.append(tmp_path / f"{i}.png")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    load(model_dir).predict_proba(paths[:3])
    assert bars == [("images", True)]
    load(model_dir, progress=False).predict_proba(paths[3:])
    assert bars[-1] == ("images", False)
