"""The report page, from a hand-made metrics dict shaped like run_experiments' output (no training here)."""

import json
import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.evaluate.calibration import reliability
from deformsim.evaluate.experiments import review_order
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.metrics_file import MetricsFile, Prediction, read_metrics
from deformsim.evaluate.pca import pixel_pca_png
from deformsim.report import html as page


def write_report(m: dict, out):
    """The report page of ``m``, a metrics.json's content, read as the report reads the file."""
    return page.write_report(MetricsFile.model_validate_json(json.dumps(m)), out)


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
                                for i, c in zip(review_order([Prediction(**p) for p in black["real"]["predictions"]], 0.5),
                                                cams)]
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
    srcs = re.findall(r"""src\s*=\s*["']?([^"'\s>]+)""", html)
    assert srcs and all(r.startswith("data:") for r in srcs)
    photos = {Path(p["path"]).resolve().as_uri() for v in m["variants"].values() for part in ("split", "real")
              for p in v[part].get("predictions", [])}
    links = re.findall(r"""href\s*=\s*["']?([^"'\s>]+)""", html)
    assert links and set(links) <= photos  # the only links: the full-size photos
    assert "url(" not in html and "@import" not in html and "<script" not in html


def test_report_shows_calibration_and_gradcam_of_the_real_photos(metrics):
    m, out = metrics
    html = write_report(m, out).read_text()
    calibration = html[html.index("Calibration on the real photographs"):html.index("Where the models look")]
    for v, e in m["variants"].items():
        preds = e["real"]["predictions"]
        ece = reliability([p["y"] for p in preds], [p["prob"] for p in preds])["ece"]
        assert f"<b>{v}</b> {ece:.3f}" in calibration
    assert calibration.count("data:image/png;base64,") == len(m["variants"])  # a figure per variant: readable on a phone
    cams = html[html.index("Where the models look"):html.index("Domain gap")]
    assert "<h3>black</h3>" in cams and "<h3>backgrounds</h3>" not in cams  # only models with heatmaps
    assert cams.count("data:image/jpeg;base64,") == 3 and "3 of the 8 photos" in cams
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


def _only(m, variant, y, prob, n_files=None, folder=None):
    """``m`` with one variant whose real test gave ``prob`` for labels ``y``."""
    paths = [str(folder / f"{i}.png") for i in range(len(y))] if folder else [f"/photos/{i}.png" for i in range(len(y))]
    m["variants"] = {variant: {"n_images": 8, "n_samples": 2, "examples": [],
                               "split": {"skipped": "too few samples"},
                               "real": _result(paths, y, prob, f"models/{variant}_full/model.pt")}}
    return m


def _hero(html):
    return html[html.index('class="hero"'):html.index("Table II")]


def test_big_number_is_green_only_when_its_interval_clears_the_baseline(metrics):
    m, out = metrics
    y = [0, 1] * 5
    chance = write_report(_only(m, "black", y, [0.9, 0.1] * 2 + [0.1, 0.9] * 3), out).read_text()  # 60 %, base 50 %
    assert 'class="big ">60.0%' in _hero(chance) and "not distinguishable from the majority baseline" in _hero(chance)
    assert "95 % interval 31.3–83.2%" in _hero(chance)  # Wilson, 6 of 10
    y = [0, 1] * 50
    good = write_report(_only(m, "black", y, [0.1, 0.9] * 45 + [0.9, 0.1] * 5), out).read_text()  # 90 %
    assert 'class="big above">90.0%' in _hero(good) and "above the majority baseline" in _hero(good)
    bad = write_report(_only(m, "black", y, [0.9, 0.1] * 45 + [0.1, 0.9] * 5), out).read_text()  # 10 %
    assert 'class="big below">10.0%' in _hero(bad)
    assert "F1" in _hero(good) and "(Wilson)" in _hero(good) and "precision 90.0% (" in _hero(good)


def test_undefined_precision_shows_a_dash_not_zero(metrics):
    m, out = metrics
    html = write_report(_only(m, "black", [0, 0, 1, 1], [0.1, 0.2, 0.3, 0.4]), out).read_text()  # none predicted deformed
    assert "precision — · recall 0.0%" in _hero(html)
    table = html[html.index('class="t2"'):html.index("</table>")]
    assert table.count(">—<") == 1 and ">0.0%<span class=ci>0.0–79.3%</span>" in table  # F1 0 is defined (Wilson)


def test_best_is_bold_only_with_a_margin(metrics):
    m, out = metrics
    html = write_report(m, out).read_text()  # black 5/8 and backgrounds 7/8: intervals overlap
    assert 'class="best"' not in html and "best" not in re.findall(r'<td class="([^"]*)"', html)
    y = [0, 1] * 100
    far = _result([f"/p/{i}.png" for i in range(200)], y, [0.1, 0.9] * 95 + [0.9, 0.1] * 5, "models/a/model.pt")
    near = _result([f"/p/{i}.png" for i in range(200)], y, [0.1, 0.9] * 50 + [0.9, 0.1] * 50, "models/b/model.pt")
    m["variants"]["black"]["real"], m["variants"]["backgrounds"]["real"] = far, near
    cells = re.findall(r'<td class="([^"]*)"[^>]*>([\d.]+%)', write_report(m, out).read_text())
    bold = [value for cls, value in cells if "best" in cls.split()]
    assert bold == ["95.0%", f"{100 * far['metrics']['f1']:.1f}%"]  # black's real accuracy and F1, nothing else


def test_every_wrong_prediction_is_listed_with_name_probability_and_link(metrics, tmp_path):
    m, out = metrics
    y = [0, 1] * 15
    prob = [0.8, 0.2] * 10 + [0.1, 0.9] * 5  # 20 wrong, 10 right
    html = write_report(_only(m, "black", y, prob, folder=tmp_path / "photos"), out).read_text()
    wrong = html[html.index("<h3>Wrong (20)"):html.index("<h3>Right (10)")]
    right = html[html.index("<h3>Right (10)"):]
    card = (r'<div class="thumb (\w+)" title="([^"]+)">(?:<img src="data:[^"]+" alt="">|<div class="missing">missing</div>)'
            r'(\w+)<br>P\(deformed\) = ([\d.]+)<div class=sub><a href="([^"]+)">([^<]+)</a></div></div>')
    rows = re.findall(card, wrong)
    assert len(rows) == 20 and "more" not in wrong and "<table" not in wrong
    for cls, path, label, p, link, name in rows:
        i = int(name.removesuffix(".png"))
        assert cls == "bad" and path == str(tmp_path / "photos" / name) and link == Path(path).resolve().as_uri()
        assert (label, float(p)) == (("intact", "deformed")[y[i]], prob[i])
    assert len(re.findall(card, right)) == 10  # the right ones: cards of the same kind and size


def test_every_name_shown_is_escaped(metrics, tmp_path):
    m, out = metrics
    hostile = '<img src=x onerror="alert(1)">&.png'
    folder = tmp_path / "evil"
    folder.mkdir()
    Image.new("RGB", (8, 8)).save(folder / hostile, format="PNG")
    m = _only(m, "<b>v</b>", [0, 1], [0.9, 0.1], folder=folder)
    pred = m["variants"]["<b>v</b>"]["real"]["predictions"]
    pred[0]["path"] = str(folder / hostile)
    m["missing_variants"] = ["<i>gone</i>"]
    html = write_report(m, out).read_text()
    assert "<img src=x" not in html and "<b>v</b>" not in html and "<i>gone</i>" not in html
    assert "&lt;img src=x onerror=&quot;alert(1)&quot;&gt;&amp;.png" in html and "&lt;b&gt;v&lt;/b&gt;" in html


def test_every_wide_table_scrolls_in_a_box_of_its_own(metrics):
    """On a narrow screen a wide table scrolls sideways inside its box, never the page (bench/report_screens.py
    measures the rendered page at a phone's width in Chromium)."""
    m, out = metrics
    html = write_report(m, out).read_text()
    assert html.count("<table") > 3  # the report has tables besides the 2x2 confusion matrices
    assert html.count("<table") == html.count("<div class=scroll><table") + html.count('<div class="cm">')


def test_a_low_held_out_synthetic_accuracy_is_a_warning_banner(metrics):
    m, out = metrics
    assert "class=warn" not in write_report(m, out).read_text()  # black's split: 3 of 4 right, 0.75
    paths = [p["path"] for p in m["variants"]["black"]["split"]["predictions"]]
    m["variants"]["black"]["split"] = _result(paths, [0, 0, 1, 1], [0.2, 0.7, 0.9, 0.3], "models/black_split/model.pt")
    html = write_report(m, out).read_text()
    banner = html[html.index("class=warn"):html.index('class="hero"')]
    assert "variant black: held-out synthetic accuracy 0.50 is below 0.75" in banner and "backgrounds" not in banner


def test_synthetic_samples_sit_beside_real_photos_of_their_class(metrics):
    m, out = metrics
    html = write_report(m, out).read_text()
    sheet = html[html.index("Synthetic samples beside the real photos"):html.index("Confusion matrices")]
    real = m["variants"]["backgrounds"]["real"]["predictions"]  # the headline model's photos
    for y, cls in enumerate(("intact", "deformed")):
        block = sheet[sheet.index(f"<h3>{cls}</h3>"):]
        block = block[:block.index("<h3>", 4)] if "<h3>" in block[4:] else block
        shown = re.findall(r'title="([^"]+)"><img[^>]*>([^<]*)</div>', block)
        assert [p for p, label in shown if label == "real photos"] == [p["path"] for p in real if p["y"] == y]
        assert [p for p, label in shown if label == "black"] == [x["path"] for x in m["variants"]["black"]["examples"]
                                                                 if x["y"] == y]
    for v in m["variants"].values():
        v.pop("real")
    html = write_report(m, out).read_text()
    assert "<h2>Synthetic samples</h2>" in html and ">real photos</div>" not in html


def test_a_metrics_file_with_text_for_a_count_is_refused_in_one_line(metrics):
    """Counts went into the page as they were: a metrics.json holding text there injected it. Such a file is no
    report's: it is refused, naming the file and the value, before any page is made."""
    m, out = metrics
    m["variants"]["black"]["n_images"] = "<script>a()</script>"
    (out / "metrics.json").write_text(json.dumps(m))
    with pytest.raises(UserError) as err:
        read_metrics(out)
    assert str(err.value) == (f"{out / 'metrics.json'} is not a deformsim report's metrics (metrics.json): "
                              "variants.black.n_images: Input should be a valid integer (got <script>a()</script>)")
    assert not (out / "report.html").exists()
