"""bench adapt's adapt.json and bench ceiling's ceiling.json as typed records: what the writers build is written
with a schema version and read back the same, a file without a version reads as version 1, a newer version or a
value of the wrong type is refused in one line naming the file."""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.adaptation import _row, kshot_curves
from deformsim.evaluate.adaptation_file import AdaptBenchFile
from deformsim.evaluate.ceiling_file import CeilingFile
from deformsim.evaluate.paired import paired_differences
from deformsim.learn.adapter import AdaptRecipe
from deformsim.records import made, read_record


def _adapt_bench() -> dict:
    """An adapt.json's content as run_adaptation builds it, of two models on 20 photos."""
    rng = np.random.default_rng(0)
    y = np.repeat([0, 1], 10)
    base = np.clip(rng.normal(0.3 + 0.4 * y, 0.2, (2, 20)), 0.01, 0.99)
    adapted = np.clip(base + 0.1 * (2 * y - 1), 0.01, 0.99)
    features = [rng.normal(size=(20, 4)) + y[:, None] for _ in range(2)]
    sessions = ["2026-01-01"] * 10 + ["2026-01-02"] * 10
    paired = {k: d.model_dump() for k, d in paired_differences(adapted, base, y, 0.5, rng).items()}
    rows = {"unadapted": {**_row(y, base, 0.5), "predictions": base.tolist()},
            "probe transductive": {**_row(y, adapted, 0.5), "paired": paired, "prior": [[0.5], [0.45]],
                                   "predictions": adapted.tolist()}}
    return {"models": ["m0/model.pt", "m1/model.pt"], "real": "real", "photos": 20, "folds": 2, "seed": 0,
            "recipe": asdict(AdaptRecipe()), "true_share": 0.5, "labels": y.tolist(), "groups": "date", "biased": False,
            "sessions": sessions, "paths": [f"real/{i}.png" for i in range(20)], "rows": rows,
            "kshot": kshot_curves(list(base), features, y, sessions, [2], 1, AdaptRecipe(), 0.5, 0), "draws": 1,
            "seconds": 2.5}


def _ceiling() -> dict:
    """A ceiling.json's content as run_ceiling builds it."""
    return {"real": "real", "photos": 40, "folds": 5, "l2": 0.1, "seed": 0, "majority": 0.55, "seconds": 12.0,
            "rows": [{"backbone": "vgg16", "size": 128, "weights": "torchvision", "features": 512, "accuracy": 0.8,
                      "f1": 0.78, "auc": 0.86, "seconds_per_photo": 0.021},
                     {"backbone": "efficientnet_lite0", "size": 224, "weights": "timm", "features": 1280,
                      "accuracy": 0.5, "f1": 0.0, "auc": None, "seconds_per_photo": 0.008}]}


RECORDS = [(AdaptBenchFile, _adapt_bench, "adapt.json"), (CeilingFile, _ceiling, "ceiling.json")]


@pytest.mark.parametrize("model, content, name", RECORDS)
def test_a_written_file_holds_what_its_writer_set_and_its_version_and_reads_back_the_same(tmp_path, model, content,
                                                                                         name):
    data = content()
    record = made(model, data)
    record.write(tmp_path / name)
    written = json.loads((tmp_path / name).read_text())
    assert written == {**json.loads(json.dumps(data)), "schema_version": 1}  # the same keys and values, and the version
    back = read_record(tmp_path / name, model)
    assert back == record and back.dump() == written
    (tmp_path / "old.json").write_text(json.dumps(data))  # written before there was a schema version
    assert read_record(tmp_path / "old.json", model).schema_version == 1


def test_the_adaptation_rows_read_as_attributes():
    record = made(AdaptBenchFile, _adapt_bench())
    unadapted, probe = record.rows["unadapted"], record.rows["probe transductive"]
    assert unadapted.paired is None and unadapted.prior is None and len(unadapted.models) == 2
    assert probe.paired["accuracy"].diff > 0 and probe.prior == [[0.5], [0.45]]
    assert [(r.k, r.curve, r.paired is None) for r in record.kshot][:2] == [(2, "unadapted", True),
                                                                          (2, "labelled probe", False)]


def test_a_ceiling_row_before_seconds_per_photo_reads_without_it(tmp_path):
    data = _ceiling()
    del data["rows"][0]["seconds_per_photo"]
    (tmp_path / "ceiling.json").write_text(json.dumps(data))
    rows = read_record(tmp_path / "ceiling.json", CeilingFile).rows
    assert [r.seconds_per_photo for r in rows] == [None, 0.008]


@pytest.mark.parametrize("model, content, name", RECORDS)
def test_a_newer_file_is_refused_in_one_line(tmp_path, model, content, name):
    path = tmp_path / name
    path.write_text(json.dumps({**content(), "schema_version": 2}))
    with pytest.raises(UserError) as err:
        read_record(path, model)
    assert str(err.value) == f"{path} has schema_version 2, newer than this deformsim reads (1): upgrade deformsim to read it"


def test_a_value_of_the_wrong_type_is_refused_naming_it(tmp_path):
    data = _adapt_bench()
    data["rows"]["unadapted"]["accuracy"] = "0.9"
    (tmp_path / "adapt.json").write_text(json.dumps(data))
    with pytest.raises(UserError) as err:
        read_record(tmp_path / "adapt.json", AdaptBenchFile)
    assert str(err.value) == (f"{tmp_path / 'adapt.json'} is not a deformsim adaptation benchmark (bench adapt's "
                              "adapt.json): rows.unadapted.accuracy: Input should be a valid number (got 0.9)")
    data = _ceiling()
    data["rows"][0]["size"] = 128.5
    (tmp_path / "ceiling.json").write_text(json.dumps(data))
    with pytest.raises(UserError, match=r"ceiling.json\): rows\[0\].size: Input should be a valid integer \(got 128.5\)$"):
        read_record(tmp_path / "ceiling.json", CeilingFile)
