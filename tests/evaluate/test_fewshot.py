"""The few-shot benchmark: a draw never puts a photo on both sides, runs score only the photos they did not adapt
on, an adapted model is refused, and the report shows the curves escaped."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.draws import draw
from deformsim.evaluate.fewshot import parse_ks, read_results, run_fewshot, unique_photos
from deformsim.evaluate.fewshot_file import FewshotFile
from deformsim.report.fewshot_html import fewshot_section
from tests.learn.blobs import make_blobs

QUICK = {"part": "head", "steps": 10, "lr": 1e-3, "views": 1}


@pytest.mark.parametrize("seed", range(5))
def test_a_draw_never_puts_a_photo_in_both_the_adaptation_and_the_scored_set(seed):
    y = np.array([0] * 5 + [1] * 8)
    np.random.default_rng(seed).shuffle(y)
    for k in range(5):
        chosen, rest = draw(y, k, np.random.default_rng([k, seed]))
        assert not set(chosen) & set(rest) and sorted([*chosen, *rest]) == list(range(len(y)))
        assert (y[chosen] == 0).sum() == (y[chosen] == 1).sum() == k
        assert {0, 1} <= set(y[rest])


def test_k_values_are_read_as_distinct_whole_numbers():
    assert parse_ks("0, 2,1,2") == [0, 1, 2]
    for bad in ("x", "-1", ""):
        with pytest.raises(UserError, match="--k"):
            parse_ks(bad)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """A tiny trained model, and labelled photos (6 + 6, one of them also under another name)."""
    from deformsim.config import TrainConfig
    from deformsim.learn.train import fit

    root = tmp_path_factory.mktemp("fewshot")
    mp = pytest.MonkeyPatch()
    mp.setenv("DEFORMSIM_CACHE", str(root / "cache"))
    model = fit(make_blobs(root / "syn", 20), TrainConfig(weights="offline", image_size=32, epochs=1, batch_size=16),
                root / "model", progress=False).model_path
    photos = make_blobs(root / "real", 6, seed=11)
    shutil.copy(photos["path"].iloc[0], root / "real" / "intact" / "copy.png")
    yield model, root / "real"
    mp.undo()


@pytest.mark.torch
def test_each_run_scores_the_photos_it_did_not_adapt_on(tiny, tmp_path):
    from deformsim.learn.finetune import Recipe

    model, real = tiny
    results = run_fewshot(real, model, tmp_path / "out", (0, 1, 2, 9), draws=2, seeds=1, recipe=Recipe(**QUICK),
                          progress=False)
    assert results.ks == [0, 1, 2, 5] and results.capped == [9]  # the copy counts once: 6 + 6 photos
    for run in results.runs:
        assert run["n_test"] == 12 - 2 * run["k"] and len(run["adapted_on"]) == 2 * run["k"]
    assert [r.k for r in results.curves["synthetic"]] == [0, 1, 2, 5]
    assert [r.k for r in results.curves["imagenet"]] == [1, 2, 5]
    assert [r.runs for r in results.curves["unadapted"]] == [2, 2, 2]  # one per draw: it trains nothing
    assert results.curves["synthetic"][0].interval == "photos"
    assert [r.majority for r in results.curves["synthetic"]] == [0.5] * 4
    for row in results.curves["imagenet"]:
        assert row.runs == 2 and row.accuracy_interval[0] <= row.accuracy <= row.accuracy_interval[1]
    assert read_results(tmp_path / "out" / "fewshot.json") == results
    assert (tmp_path / "out" / "fewshot.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.torch
def test_a_biased_fewshot_adapts_each_class_on_photos_of_another_lighting(tiny, tmp_path):
    from deformsim.evaluate.draws import warm_half
    from deformsim.learn.finetune import Recipe

    model, real = tiny
    results = run_fewshot(real, model, tmp_path / "out", (1,), draws=2, seeds=1, recipe=Recipe(**QUICK),
                          curves=("synthetic",), progress=False, biased=True)
    table = unique_photos(real)
    warm = dict(zip(table["id"], warm_half(list(table["path"]))))
    label = dict(zip(table["id"], table["y"]))
    assert results.biased and len(results.runs) == 2
    for run in results.runs:  # intact from the warm half in draw 0, from the cool half in draw 1
        sides = {label[i]: warm[i] for i in run["adapted_on"]}
        assert sides == {0: run["draw"] == 0, 1: run["draw"] != 0}
    short = r"^--biased --k 5: .* holds \d (warm|cool)-lit (intact|deformed) photos; the biased draw needs 5"
    with pytest.raises(UserError, match=short):
        run_fewshot(real, model, tmp_path / "out5", (5,), draws=1, seeds=1, recipe=Recipe(**QUICK), progress=False,
                    biased=True)
    assert not (tmp_path / "out5").exists()


@pytest.mark.torch
def test_the_same_inputs_give_the_same_fewshot_json_and_plot(tiny, tmp_path):
    from deformsim.learn.finetune import Recipe

    model, real = tiny
    written = []
    for name in ("a", "b"):
        run_fewshot(real, model, tmp_path / name, (0, 1, 2), draws=2, seeds=2, recipe=Recipe(**QUICK), progress=False)
        results = json.loads((tmp_path / name / "fewshot.json").read_text())
        del results["created"], results["seconds"]  # the clock's
        written.append((json.dumps(results), (tmp_path / name / "fewshot.png").read_bytes()))
    assert written[0] == written[1]
    assert len(json.loads(written[0][0])["runs"]) == 1 + 2 * (2 + 1 + 2) * 2  # k 0 once; per draw 2 + 1 + 2 runs


@pytest.mark.torch
def test_a_model_adapted_on_the_folder_is_refused(tiny, tmp_path):
    from deformsim.learn.finetune import Recipe, finetune

    model, real = tiny
    adapted = finetune(model, real, tmp_path / "ft", Recipe(**QUICK), progress=False).model_path
    with pytest.raises(UserError, match="learnt from the labels of 12 of these images"):
        run_fewshot(real, adapted, tmp_path / "out", (0, 1), draws=1, seeds=1, recipe=Recipe(**QUICK), progress=False)
    assert not (tmp_path / "out").exists()


def test_the_report_section_escapes_names_and_a_foreign_file_is_refused(tmp_path):
    row = {"k": 1, "runs": 2, "interval": "runs", "accuracy": 0.7, "f1": 0.6, "accuracy_interval": [0.6, 0.8],
           "f1_interval": [0.5, 0.7], "majority": 0.5}
    results = {"kind": "fewshot", "real_dir": "<script>x</script>", "model": "m&m", "majority_baseline": 0.5,
               "photos": {"intact": 3, "deformed": 3}, "draws": 2, "seeds": 1,
               "curves": {"synthetic": [row], "imagenet": [row]}}
    html = fewshot_section(FewshotFile.model_validate_json(json.dumps(results)))
    assert "&lt;script&gt;" in html and "<script>" not in html and "m&amp;m" in html and "70.0%" in html
    (tmp_path / "f.json").write_text(json.dumps(results))
    assert read_results(tmp_path / "f.json").model == "m&m"
    (tmp_path / "g.json").write_text(json.dumps({**results, "kind": "sim2real"}))
    with pytest.raises(UserError, match=r"^--fewshot .*g.json is not a deformsim few-shot result"):
        read_results(tmp_path / "g.json")


@pytest.mark.torch
def test_the_unadapted_curve_scores_as_evaluate_does_with_test_time_crop_and_flip(tiny, tmp_path):
    from deformsim.config import TrainConfig
    from deformsim.evaluate.experiments import evaluate_model
    from deformsim.learn.finetune import Recipe
    from deformsim.learn.train import fit

    _, real = tiny
    cfg = TrainConfig(weights="offline", image_size=32, epochs=1, batch_size=16, tta_flip=True, crop="saliency")
    model = fit(make_blobs(tmp_path / "syn", 10), cfg, tmp_path / "model", progress=False).model_path
    results = run_fewshot(real, model, tmp_path / "out", (0,), draws=1, seeds=1, recipe=Recipe(**QUICK), progress=False)
    shutil.copytree(real, tmp_path / "unique", ignore=shutil.ignore_patterns("copy.png"))  # as fewshot counts them
    expected = evaluate_model(model, real_dir=tmp_path / "unique").metrics.accuracy
    assert results.curves["synthetic"][0].accuracy == pytest.approx(expected)
    assert read_results(tmp_path / "out" / "fewshot.json").curves.keys() == results.curves.keys()  # k = 0 only


XSS = ("<script>alert(1)</script>", "<img src=x onerror=alert(1)>", "<svg onload=alert(1)>")


def _shots() -> dict:
    row = {"k": 1, "runs": 2, "interval": "draws", "accuracy": 0.7, "f1": 0.6, "accuracy_interval": [0.6, 0.8],
           "f1_interval": [0.5, 0.7], "majority": 0.5}
    return {"kind": "fewshot", "real_dir": "r", "model": "m", "majority_baseline": 0.5,
            "photos": {"intact": 3, "deformed": 3}, "draws": 2, "seeds": 1, "curves": {"synthetic": [row]}}


@pytest.mark.parametrize("where, value, said", [
    (("photos", "intact"), XSS[0], r"photos.intact: Input should be a valid integer \(got <script>"),
    (("draws",), XSS[1], "draws: Input should be a valid integer"),
    (("seeds",), XSS[2], "seeds: Input should be a valid integer"),
    (("curves", "synthetic", 0, "k"), XSS[1], r"curves.synthetic\[0\].k: Input should be a valid integer"),
    (("draws",), [1, 2], r"draws: Input should be a valid integer \(got \[1, 2\]\)"),  # was a TypeError
    (("photos",), None, "photos: Field required"),  # was a KeyError
    (("curves", "synthetic"), [], "curves.synthetic: List should have at least 1 item"),
    (("majority_baseline",), float("nan"), "majority_baseline: Input should be a finite number"),
    (("real_dir",), 5, "real_dir: Input should be a valid string"),
    (("runs",), "x" * 10, "runs: Input should be a valid array"),
])
def test_a_fewshot_file_off_its_schema_is_one_line_naming_the_value(tmp_path, where, value, said):
    results = _shots()
    node = results
    for key in where[:-1]:
        node = node[key]
    if value is None:
        del node[where[-1]]
    else:
        node[where[-1]] = value
    (tmp_path / "f.json").write_text(json.dumps(results))
    with pytest.raises(UserError, match=rf"is not a deformsim few-shot result .*: {said}") as err:
        read_results(tmp_path / "f.json")
    assert "\n" not in str(err.value)


def test_a_fewshot_file_nested_deep_or_not_json_is_one_line(tmp_path):
    for text, said in (("[" * 100_000, "nested too deeply"), ("{", "not JSON")):
        (tmp_path / "f.json").write_text(text)
        with pytest.raises(UserError, match=said):
            read_results(tmp_path / "f.json")


def test_a_fewshot_file_round_trips_an_older_one_reads_and_a_newer_one_is_refused(tmp_path):
    from deformsim.records import made

    shots = _shots()
    (tmp_path / "old.json").write_text(json.dumps(shots))  # as written before the schema version
    old = read_results(tmp_path / "old.json")
    assert old.schema_version == 1 and old.curves["synthetic"][0].accuracy == 0.7
    made(FewshotFile, shots).write(tmp_path / "new.json")
    assert json.loads((tmp_path / "new.json").read_text()) == shots | {"schema_version": 1}
    assert read_results(tmp_path / "new.json") == made(FewshotFile, shots)
    (tmp_path / "newer.json").write_text(json.dumps(shots | {"schema_version": 2}))
    with pytest.raises(UserError, match=r"^--fewshot .*newer.json has schema_version 2, newer than this deformsim reads"):
        read_results(tmp_path / "newer.json")
