"""The report page, from a hand-made metrics dict shaped like run_experiments' output (no training here)."""

import os
import re

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.evaluate.calibration import reliability
from deformsim.evaluate.experiments import review_order
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.pca import pixel_pca_png
from deformsim.report.html import write_report


def _images(folder, n, rng):
    folder.mkdir(parents=True)
    paths = []
    for i in range(n):
        p = folder / f"{i}.png"
        Image.fromarray(rng.integers(0, 255, (48, 40, 3), dtype=np.uint8)).save(p)
        paths.append(str(p))
    return paths


def _result(paths, y, prob, model):
    return {
        "train": {"n": 40, "n_deformed": 20, "n_samples": 10},
        "test": {"n": len(y), "n_deformed": int(sum(y))},
        "model": model, "weights": "offline",
        "history": [{"epoch": 1, "loss": 0.7, "acc": 0.55, "seconds": 1.0},
                    {"epoch": 2, "loss": 0.4, "acc": 0.8, "seconds": 1.0}],
        "train_seconds": 2.0, "predict_seconds": 0.5,
        "metrics": compute_metrics(y, prob, 0.5),
        "predictions": [{"path": p, "y": a, "prob": b} for p, a, b in zip(paths, y, prob)],
    }


@pytest.fixture
def metrics(tmp_path):
    rng = np.random.default_rng(0)
    syn = _images(tmp_path / "syn", 8, rng)
    real = _images(tmp_path / "real", 8, rng)
    y = [0, 0, 0, 0, 1, 1, 1, 1]
    out = tmp_path / "report"
    out.mkdir()
    domains = {"synthetic black": pd.DataFrame({"path": syn, "y": y}), "real": pd.DataFrame({"path": real, "y": y})}
    (out / "pca_pixels.png").write_bytes(pixel_pca_png(domains))
    black = {
        "n_images": 8, "n_samples": 2,
        "examples": [{"path": p, "y": a} for p, a in zip(syn[:2] + syn[-2:], [0, 0, 1, 1])],
        "split": _result(syn[:4], [0, 0, 1, 1], [0.2, 0.7, 0.9, 0.8], "models/black_split/model.pt"),
        "real": _result(real, y, [0.1, 0.2, 0.3, 0.9, 0.6, 0.8, 0.4, 0.95], "models/black_full/model.pt"),
    }
    cams = _images(out / "gradcam" / "black", 3, rng)  # stand-ins for run_experiments' heatmaps of 3 photos
    black["real"]["gradcam"] = [{**black["real"]["predictions"][i], "image": os.path.relpath(c, out)}
                                for i, c in zip(review_order(black["real"]["predictions"], 0.5), cams)]
    backgrounds = {"n_images": 8, "n_samples": 2, "examples": [],
                   "split": {"skipped": "a split needs at least 2 samples of each class, got 1 with y=0"},
                   "real": _result(real, y, [0.4] * 4 + [0.6, 0.6, 0.6, 0.2], "models/backgrounds_full/model.pt")}
    return {
        "created": "2025-01-01T00:00:00+00:00", "data_root": str(tmp_path / "data"), "real_dir": str(tmp_path / "real"),
        "real": {"n": 8, "n_deformed": 4}, "settings": TrainConfig(weights="offline").model_dump(mode="json"),
        "missing_variants": ["green"], "variants": {"black": black, "backgrounds": backgrounds},
        "plots": {"pca_pixels": "pca_pixels.png", "pca_features": {}}, "seconds": 12.0,
    }, out


def test_report_shows_the_numbers_and_is_self_contained(metrics):
    m, out = metrics
    path = write_report(m, out)
    html = path.read_text()
    assert not (out / "metrics.json").exists()  # run_experiments writes it; the report only renders
    # headline: best sim-to-real accuracy (backgrounds: 7/8) and every Table II number
    hero = html[html.index('class="hero"'):html.index("Table II")]
    assert "87.5%" in hero and "backgrounds" in hero
    for v in m["variants"].values():
        for part in ("split", "real"):
            if "metrics" in v[part]:
                for k in ("accuracy", "f1", "precision", "recall"):
                    assert f"{100 * v[part]['metrics'][k]:.1f}%" in html
    assert "at least 2 samples of each class" in html  # the skipped experiment says why
    for (tn, fp), (fn, tp) in [v["real"]["metrics"]["confusion"]["matrix"] for v in m["variants"].values()]:
        assert re.search(rf">{tn}</td>.*?>{fp}</td>.*?>{fn}</td>.*?>{tp}</td>", html, re.S)
    # images inlined: PCA + curves (PNG), thumbnails (JPEG); nothing fetched from elsewhere
    assert html.count("data:image/png;base64,") >= 2
    assert html.count("data:image/jpeg;base64,") >= 8 + 4
    refs = re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]+)""", html)
    assert refs and all(r.startswith("data:") for r in refs)
    assert "url(" not in html and "@import" not in html and "<script" not in html


def test_report_shows_calibration_and_gradcam_of_the_real_photos(metrics):
    m, out = metrics
    html = write_report(m, out).read_text()
    calibration = html[html.index("Calibration on the real photographs"):html.index("Where the models look")]
    for v, e in m["variants"].items():
        preds = e["real"]["predictions"]
        ece = reliability([p["y"] for p in preds], [p["prob"] for p in preds])["ece"]
        assert f"<b>{v}</b> {ece:.3f}" in calibration
    assert calibration.count("data:image/png;base64,") == 1  # one figure, a diagram per variant
    cams = html[html.index("Where the models look"):html.index("Domain gap")]
    assert "<h3>black</h3>" in cams and "<h3>backgrounds</h3>" not in cams  # only models with heatmaps
    assert cams.count("data:image/jpeg;base64,") == 3 and "… and 5 more photos" in cams
    # misclassified first (red, most confident first), then the least confident right one; captions give the
    # label, P(deformed) and file name
    captions = re.findall(r'class="thumb cam (\w+)" title="([^"]+)"><img [^>]+>(.*?)<div class=sub>(.*?)</div>', cams)
    assert [(c[0], c[2], c[3]) for c in captions] == [("bad", "intact · P(deformed) 0.90", "3.png"),
                                                        ("bad", "deformed · P(deformed) 0.40", "6.png"),
                                                        ("ok", "deformed · P(deformed) 0.60", "4.png")]
    assert [c[1] for c in captions] == [g["path"] for g in m["variants"]["black"]["real"]["gradcam"]]


def test_report_without_real_data_headlines_the_synthetic_test(metrics):
    m, out = metrics
    for v in m["variants"].values():
        v.pop("real")
    m["real_dir"] = m["real"] = None
    html = write_report(m, out).read_text()
    assert "held-out synthetic" in html
    hero = html[html.index('class="hero"'):html.index("Table II")]
    assert "75.0%" in hero  # black split: 3 of 4 right
    assert "no real folder given" in html
