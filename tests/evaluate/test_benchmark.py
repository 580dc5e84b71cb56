"""The sim-to-real benchmark: its aggregation and plan checks, what its training reads and what it trains on."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from deformsim.errors import UserError
from deformsim.evaluate.benchmark import Plan, aggregate
from deformsim.evaluate.results import Run


def _run(variant, acc, f1, prec, rec, synth, auc=None):
    return Run(variant=variant, data_seed=0, composite_seed=None, train_seed=0, model="m", real_predictions=[],
               real={"accuracy": acc, "f1": f1, "precision": prec, "recall": rec, "auc": synth if auc is None else auc,
                     "confusion": [[0, 0], [0, 0]]},
               synthetic={"accuracy": synth, "f1": synth})


def test_aggregate_gives_mean_and_sample_std_per_variant():
    runs = [_run("backgrounds", 0.6, 0.5, 1.0, 0.4, 0.9), _run("backgrounds", 0.8, 0.7, 0.8, 0.6, 0.95),
            _run("backgrounds", 0.7, 0.9, 0.9, 0.8, 1.0), _run("black", 0.5, 0.3, 1.0, 0.2, 0.92)]
    s = aggregate(runs)
    assert list(s) == ["backgrounds", "black"]
    bg = s["backgrounds"]
    assert bg.n_runs == 3
    # by hand: mean 0.7; deviations -0.1, 0.1, 0 -> sample variance 0.02 / 2 = 0.01 -> std 0.1
    assert bg.spread("accuracy") == pytest.approx((0.7, 0.1))
    assert bg.spread("f1") == pytest.approx((0.7, 0.2))
    assert bg.spread("precision") == pytest.approx((0.9, 0.1))
    assert bg.spread("recall") == pytest.approx((0.6, 0.2))
    assert bg.spread("synthetic_accuracy") == pytest.approx((0.95, 0.05))
    assert bg.spread("auc") == pytest.approx((0.95, 0.05))
    assert s["black"].n_runs == 1 and s["black"].accuracy_std == 0.0


@pytest.mark.parametrize("kwargs", [{"train_seeds": 0}, {"composite_seeds": -1}, {"variants": ()}])
def test_bad_plans_fail_with_one_line(kwargs):
    with pytest.raises(UserError, match="benchmark"):
        Plan(**kwargs)


def _tiny(tmp_path, monkeypatch):
    """A tiny benchmark's config (16 renders of 32 px) and a folder of 6 labelled photos; the cache under tmp_path."""
    from PIL import Image

    from deformsim.config import load_config

    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path / "cache"))
    real = tmp_path / "real"
    for k, label in enumerate(["intact"] * 3 + ["deformed"] * 3):
        (real / label).mkdir(parents=True, exist_ok=True)
        Image.new("RGB", (40, 30), (40 * k, 90, 200 - 30 * k)).save(real / label / f"{k}.png")
    cfg = load_config("quick", {"generate.n": 16, "render.resolution": 32, "render.samples": 1, "generate.seed": 4,
                                "train.epochs": 1, "train.image_size": 32, "train.weights": "none"})
    return cfg, real


@pytest.mark.blender
@pytest.mark.torch
def test_training_reads_nothing_under_the_real_folder(tmp_path, monkeypatch):
    """The real photos' labels (their folders) are only read to score: training never opens or lists them."""
    import sys

    from deformsim.evaluate.benchmark import Plan, run_benchmark
    from deformsim.learn import train

    cfg, real = _tiny(tmp_path, monkeypatch)
    touched, training = [], [False]

    def hook(event, args):
        if training[0] and event in ("open", "os.listdir", "os.scandir") and args and str(args[0]).startswith(str(real)):
            touched.append((event, str(args[0])))

    sys.addaudithook(hook)
    real_fit = train.fit

    def watched_fit(*a, **k):
        training[0] = True
        try:
            return real_fit(*a, **k)
        finally:
            training[0] = False

    monkeypatch.setattr(train, "fit", watched_fit)
    results = run_benchmark(cfg, tmp_path / "bench", real, Plan(composite_seeds=1, train_seeds=1, variants=("black",)),
                            progress=False)
    assert touched == []
    assert results.variants["black"].n_runs == 1 and results.real_images == 6
    assert results.threshold == 0.5


@pytest.mark.blender
@pytest.mark.torch
def test_whole_trains_on_every_render_and_scores_its_validation_split(tmp_path, monkeypatch):
    """With --whole a run's model is the one deformsim run would train (every render); its synthetic score is that
    of the renders its training held out for validation (out of bag for an ensemble), and the results say how the
    models were trained."""
    from deformsim.evaluate.benchmark import run_benchmark

    cfg, real = _tiny(tmp_path, monkeypatch)
    plan = Plan(train_seeds=1, variants=("black",), whole=True)
    for ensemble in (1, 2):
        cfg.train.ensemble = ensemble
        results = run_benchmark(cfg, tmp_path / f"bench{ensemble}", real, plan, progress=False)
        assert results.plan.whole is True and len(results.runs) == 1
        trained = json.loads((Path(results.runs[0].model) / "train.json").read_text())
        assert trained["n_train"] + trained["n_val"] == 16  # every render
        held = trained["ensemble"] if ensemble > 1 else trained["history"][-1]
        assert results.runs[0].synthetic.accuracy == pytest.approx(held["val_acc"], abs=1e-6)


def test_a_variant_composited_before_the_dataset_grew_is_composited_again(tmp_path):
    """``bench sim2real --quick`` then the full one: the dataset grows from 320 to 640 images, its variants too."""
    import pandas as pd

    from deformsim.config import CompositeConfig
    from deformsim.evaluate.benchmark import _composite_once
    from tests.fake_dense import make_dense_dataset

    data = make_dense_dataset(tmp_path / "data", n_samples=4, dense=False)
    comp = CompositeConfig(workers=1)
    manifest = data / "variants" / "procedural-x-seed0" / "manifest.parquet"
    _composite_once(data, comp, "procedural-x-seed0", 0, progress=False)
    first = manifest.stat().st_mtime_ns
    _composite_once(data, comp, "procedural-x-seed0", 0, progress=False)
    assert manifest.stat().st_mtime_ns == first  # same settings, same images: reused
    make_dense_dataset(data, n_samples=6, dense=False)
    _composite_once(data, comp, "procedural-x-seed0", 0, progress=False)
    assert len(pd.read_parquet(manifest)) == 12


def test_a_variant_is_composited_again_when_a_background_photo_changes(tmp_path):
    """The same folder of background photos, one photo edited: the benchmark's variant is not reused."""
    from PIL import Image

    from deformsim.config import CompositeConfig
    from deformsim.evaluate.benchmark import _composite_once
    from tests.fake_dense import make_dense_dataset

    data = make_dense_dataset(tmp_path / "data", n_samples=2, dense=False)
    photos = tmp_path / "photos"
    photos.mkdir()
    for i, colour in enumerate(((200, 40, 40), (40, 200, 40))):
        Image.new("RGB", (96, 96), colour).save(photos / f"{i}.png")
    comp = CompositeConfig(workers=1, backgrounds=photos)
    manifest = data / "variants" / "backgrounds-x-seed0" / "manifest.parquet"
    _composite_once(data, comp, "backgrounds-x-seed0", 0, progress=False)
    first = manifest.stat().st_mtime_ns
    _composite_once(data, comp, "backgrounds-x-seed0", 0, progress=False)
    assert manifest.stat().st_mtime_ns == first  # the same photos: reused
    Image.new("RGB", (96, 96), (40, 40, 200)).save(photos / "1.png")
    _composite_once(data, comp, "backgrounds-x-seed0", 0, progress=False)
    assert manifest.stat().st_mtime_ns != first
