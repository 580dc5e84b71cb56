"""deformsim adapt's adapt.json as a typed record: written with a schema version and read back the same, a file
without a version read as version 1, a newer one or a value of the wrong type refused in one line naming the file."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from deformsim.errors import UserError
from deformsim.learn.adapt_file import AdaptFile
from deformsim.learn.adapt_stage import Adapted
from deformsim.learn.adapter import AdaptRecipe
from deformsim.learn.stack import Choice
from deformsim.records import made, read_record


def _content(choice: Choice | None) -> dict:
    """An adapt.json's content as adapt_model builds it."""
    result = Adapted(Path("m2/model.pt"), 12, 0.4, 0.25, 0.5, 3.0, 12, choice)
    return {"model": "m/model.pt", "groups": "date", "recipe": asdict(AdaptRecipe(method="stack")),
            "folders": {"photos": None, "labelled": "real"}, "protocol": "unlabelled photos' labels never read",
            **{k: v for k, v in asdict(result).items() if k != "model_path"}}


@pytest.mark.parametrize("choice", [Choice(0.1, 5, {"none": 0.6, "0.1": 0.5}), None])
def test_a_written_file_holds_what_its_writer_set_and_its_version_and_reads_back_the_same(tmp_path, choice):
    content = _content(choice)
    record = made(AdaptFile, content)
    record.write(tmp_path / "adapt.json")
    written = json.loads((tmp_path / "adapt.json").read_text())
    assert written == {**json.loads(json.dumps(content)), "schema_version": 1}
    back = read_record(tmp_path / "adapt.json", AdaptFile)
    assert back == record and back.dump() == written
    assert back.recipe.method == "stack" and back.folders.photos is None and back.labelled == 12
    assert back.choice == (None if choice is None else made(AdaptFile, content).choice)
    (tmp_path / "old.json").write_text(json.dumps(content))  # written before there was a schema version
    assert read_record(tmp_path / "old.json", AdaptFile).schema_version == 1


def test_a_newer_or_mistyped_file_is_refused_in_one_line(tmp_path):
    path = tmp_path / "adapt.json"
    path.write_text(json.dumps({**_content(None), "schema_version": 2}))
    with pytest.raises(UserError) as err:
        read_record(path, AdaptFile)
    assert str(err.value) == f"{path} has schema_version 2, newer than this deformsim reads (1): upgrade deformsim to read it"
    path.write_text(json.dumps({**_content(None), "photos": "12"}))
    with pytest.raises(UserError) as err:
        read_record(path, AdaptFile)
    assert str(err.value) == (f"{path} is not a deformsim adaptation (deformsim adapt's adapt.json): photos: Input "
                              "should be a valid integer (got 12)")
