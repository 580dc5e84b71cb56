"""metrics.json and evaluate's --out file as typed records: written with a schema version, read back the same, an
older file (no version) read, anything else refused in one line naming the file."""

from __future__ import annotations

import json

import pytest

from deformsim.errors import UserError
from deformsim.evaluate.metrics_file import Evaluation, MetricsFile, read_metrics
from deformsim.records import made, read_record
from tests.report.made import experiment, metrics_file


def _content() -> dict:
    """A metrics.json's content as version 0.2.0 wrote it (no schema_version)."""
    real = experiment([0, 0, 1, 1], [0.1, 0.7, 0.8, 0.9], "models/black_full/model.pt")
    real["gradcam"] = [{**real["predictions"][1], "image": "gradcam/black/0.png"}]
    return metrics_file({"black": {"n_images": 8, "n_samples": 2, "examples": [{"path": "/s/0.png", "y": 0}],
                                   "split": {"skipped": "a split needs at least 2 samples of each class"},
                                   "real": real,
                                   "summary": {"split": None, "real": {k: real["metrics"][k] for k in
                                                                       ("accuracy", "f1", "precision", "recall")}}}},
                        created="2026-01-01T00:00:00+00:00", data_root="/d", real_dir="/r",
                        real={"n": 4, "n_deformed": 2}, version="0.2.0",
                        data={"config": None, "inputs": {"mesh": "ab"}, "composite": {}}, missing_variants=[],
                        plots={"pca_pixels": "pca_pixels.png", "pca_features": {"black": "pca_features_black.png"}},
                        seconds=3.5, dense={"variant": "black", "skipped": "too few samples"})


def test_a_written_file_holds_what_its_writer_set_and_its_version_and_reads_back_the_same(tmp_path):
    content = _content()
    record = made(MetricsFile, content)
    record.write(tmp_path / "metrics.json")
    written = json.loads((tmp_path / "metrics.json").read_text())
    assert written == {**json.loads(json.dumps(content)), "schema_version": 1}  # no key added but the version
    back = read_metrics(tmp_path)
    assert back == record and back.dump() == written
    assert back.variants["black"].real.gradcam[0].image == "gradcam/black/0.png"
    assert back.variants["black"].ran("split") is None and back.variants["black"].split.skipped.startswith("a split")


def test_a_file_of_version_0_2_0_without_a_schema_version_is_read_as_version_1(tmp_path):
    (tmp_path / "metrics.json").write_text(json.dumps(_content()))
    old = read_metrics(tmp_path / "metrics.json")
    assert old.schema_version == 1 and old.version == "0.2.0"
    assert [(v, part, test.metrics.accuracy) for v, part, test in old.results()] == [("black", "real", 0.75)]


@pytest.mark.parametrize("text, said", [
    (lambda c: json.dumps({**c, "schema_version": 2}),
     "{path} has schema_version 2, newer than this deformsim reads (1): upgrade deformsim to read it"),
    (lambda c: json.dumps({**c, "seconds": "3.5"}),
     "{path} is not a deformsim report's metrics (metrics.json): seconds: Input should be a valid number (got 3.5)"),
    (lambda c: json.dumps({**c, "variants": {"black": {**c["variants"]["black"], "n_images": 8.5}}}),
     "{path} is not a deformsim report's metrics (metrics.json): variants.black.n_images: Input should be a valid "
     "integer (got 8.5)"),
    (lambda c: json.dumps({k: v for k, v in c.items() if k != "variants"}),
     "{path} is not a deformsim report's metrics (metrics.json): variants: Field required"),
    (lambda c: json.dumps({**c, "extra": 1}),
     "{path} is not a deformsim report's metrics (metrics.json): extra: Extra inputs are not permitted (got 1)"),
    (lambda c: "{not json", "{path} is not a deformsim report's metrics (metrics.json): not JSON"),
    (lambda c: "[1, 2]", "{path} is not a deformsim report's metrics (metrics.json): it holds list [1, 2], not a JSON "
                         "object"),
])
def test_a_file_that_is_no_report_or_a_newer_one_is_refused_in_one_line_naming_it(tmp_path, text, said):
    path = tmp_path / "metrics.json"
    path.write_text(text(_content()))
    with pytest.raises(UserError) as err:
        read_metrics(tmp_path)
    assert str(err.value) == said.format(path=path)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(UserError, match=f"^{tmp_path / 'metrics.json'}: no such file"):
        read_metrics(tmp_path)


def test_evaluate_output_round_trips_with_its_version(tmp_path):
    content = {"model": "m", "test": "/r", "n_images": 4, "held_out": False,
               **{k: v for k, v in experiment([0, 0, 1, 1], [0.1, 0.2, 0.3, 0.4], "m").items()
                  if k in ("metrics", "predictions")}}
    made(Evaluation, content).write(tmp_path / "e.json")
    assert json.loads((tmp_path / "e.json").read_text()) == {**content, "schema_version": 1}
    back = read_record(tmp_path / "e.json", Evaluation).metrics
    assert (back.accuracy, back.value("precision"), back.interval_of("precision")) == (0.5, None, None)  # undefined
