"""The benchmark page, from a hand-made results record as run_benchmark's results.json holds it (no training here)."""

import re
from pathlib import Path

import pytest

from deformsim.evaluate.benchmark import aggregate
from deformsim.evaluate.calibration import reliability
from deformsim.evaluate.results import Baseline, ResultsFile, Run
from deformsim.records import made
from deformsim.report.benchmark import write_benchmark_report

HOSTILE = r"<script>alert('$\x$')</script>"  # markup for the page, bad math for matplotlib
LABELS = [0, 0, 1, 1]


def _run(variant, composite_seed, train_seed, acc, f1, prob):
    return Run.model_validate({"variant": variant, "data_seed": 0, "composite_seed": composite_seed, "train_seed": train_seed,
            "model": f"models/{variant}-{train_seed}",
            "real": {"accuracy": acc, "f1": f1, "precision": 0.5, "recall": 0.75, "auc": 0.8, "confusion": [[1, 1], [0, 2]]},
            "synthetic": {"accuracy": 0.9, "f1": 0.88}, "real_predictions": prob})


@pytest.fixture
def results():
    runs = [_run("black", None, 0, 0.5, 0.4, [0.1, 0.6, 0.7, 0.2]), _run("black", None, 1, 0.75, 0.6, [0.2, 0.4, 0.9, 0.8]),
            _run(HOSTILE, 0, 0, 0.8, 0.7, [0.1, 0.1, 0.9, 0.9]), _run(HOSTILE, 1, 0, 0.9, 0.8, [0.3, 0.2, 0.6, 0.7])]
    return made(ResultsFile, {"created": "2025-01-01T00:00:00+00:00", "real_dir": "/photos", "real_images": 4,
            "real_paths": ["/photos/a.jpg", "/photos/b.jpg", "/photos/c.jpg", "/photos/d.jpg"], "real_labels": LABELS,
            "majority_baseline": 0.5, "adapt": None, "seconds": 12.0,
            "plan": {"data_seeds": 1, "composite_seeds": 2, "train_seeds": 2, "variants": ["black", HOSTILE]},
            "settings": {"train": {"epochs": 15, "threshold": 0.5}}, "variants": aggregate(runs), "runs": runs})


def test_benchmark_report_shows_mean_and_std_of_every_variant(results, tmp_path):
    path = write_benchmark_report(results, tmp_path / "bench")
    assert path == tmp_path / "bench" / "report.html" and path.is_file()
    html = path.read_text()
    assert "62.5 ± 17.7" in html  # black accuracy: mean 0.625, sample std 0.177
    for v, s in results.variants.items():
        for k in ("accuracy", "f1", "precision", "recall", "synthetic_accuracy"):
            mean, std = s.spread(k)
            assert f"{100 * mean:.1f} ± {100 * std:.1f}" in html
        pooled = [p for r in results.of(v) for p in r.real_predictions]
        assert f"{reliability(LABELS * 2, pooled)['ece']:.3f}" in html
    assert "<td>black</td>" in html and html.count("<tr title=") == 4  # every run in the runs table
    assert "85.0%" in html  # the hero: the best mean real accuracy
    # the hostile name is shown, escaped, and never as markup
    assert "<script" not in html and r"&lt;script&gt;alert(&#x27;$\x$&#x27;)&lt;/script&gt;" in html
    # self-contained: bar chart and reliability diagrams inlined; links only to the photos' full-size files
    assert html.count("data:image/png;base64,") == 2
    srcs = re.findall(r"""src\s*=\s*["']?([^"'\s>]+)""", html)
    assert srcs and all(r.startswith("data:") for r in srcs)
    hrefs = set(re.findall(r"""href\s*=\s*["']?([^"'\s>]+)""", html))
    assert hrefs <= {Path(p).resolve().as_uri() for p in results.real_paths}


def test_benchmark_big_number_is_green_only_when_every_run_beats_the_baseline(results, tmp_path):
    html = write_benchmark_report(results, tmp_path).read_text()  # best: 0.8 and 0.9 against 0.5
    assert 'class="big above">85.0%' in html and "every run above the majority baseline" in html
    results.majority_baseline = 0.85
    html = write_benchmark_report(results, tmp_path).read_text()
    assert 'class="big ">85.0%' in html and "runs on both sides of the majority baseline" in html


def test_benchmark_report_shows_the_ensembles_and_the_difference_to_a_baseline(results, tmp_path):
    from deformsim.evaluate.paired import compare, ensembles

    results.ensembles = ensembles(results)
    results.baseline = Baseline(results=f"/runs/{HOSTILE}/results.json", comparison=compare(results, results))
    html = write_benchmark_report(results, tmp_path / "bench").read_text()
    assert "Ensembles of the training seeds" in html and "<td>1 x 2</td>" in html  # black: one draw of two seeds
    e = results.ensembles["black"]
    assert f"{100 * e.accuracy_mean:.1f} ± {100 * e.accuracy_std:.1f}" in html
    assert "Difference to the baseline" in html and "+0.0 (+0.0 to +0.0)" in html
    assert "<script" not in html


def test_benchmark_report_warns_when_the_synthetic_accuracy_is_low(results, tmp_path):
    assert "class=warn" not in write_benchmark_report(results, tmp_path / "a").read_text()  # 0.9 on the renders
    for run in results.of("black"):
        run.synthetic.accuracy = 0.6
    results.variants = aggregate(results.runs)
    html = write_benchmark_report(results, tmp_path / "b").read_text()
    banner = html[html.index("class=warn"):html.index('class="hero"')]
    assert "variant black: mean held-out synthetic accuracy 0.60 is below 0.75" in banner and banner.count("warn") == 1


def test_benchmark_report_lists_the_photos_most_often_wrong_first(results, tmp_path):
    results.runs[1].real_predictions = [0.2, 0.7, 0.9, 0.8]  # black: b.jpg (intact) now wrong in both runs
    html = write_benchmark_report(results, tmp_path).read_text()
    section = html[html.index("Photos most often wrong"):]
    black, hostile = section.split("<h3>")[1:3]
    assert black.startswith("black: 2 of 4 photos wrong in a run")
    rows = black.split("<tr>")[2:]  # b.jpg twice (mean P 0.65), then d.jpg (labelled deformed, 0.2 and 0.8) once
    assert "b.jpg" in rows[0] and "<td>intact</td><td>2 of 2</td><td>0.650</td>" in rows[0]
    assert "d.jpg" in rows[1] and "<td>deformed</td><td>1 of 2</td><td>0.500</td>" in rows[1]
    assert "a.jpg" not in black and "c.jpg" not in black  # right in every run
    assert "0 of 4 photos wrong in a run" in hostile and "none" in hostile and "<script" not in hostile
