"""Output folders: replaced whole or not at all."""

from __future__ import annotations

import pytest

from deformsim.errors import UserError
from deformsim.outputs import check_file_target, check_folder_target, claim, read_inputs, replacing


def test_replacing_swaps_in_whole_or_leaves_the_old_folder(tmp_path):
    out = tmp_path / "model"
    with replacing(out, {"settings": 1}, "model") as tmp:
        (tmp / "model.pt").write_text("one")
        (tmp / "extra.txt").write_text("only in the first")
    assert read_inputs(out) == {"kind": "model", "settings": 1}
    with pytest.raises(KeyboardInterrupt), replacing(out, {"settings": 2}, "model") as tmp:
        (tmp / "model.pt").write_text("two")
        raise KeyboardInterrupt  # Ctrl-C halfway: the old model stays as it was
    assert (out / "model.pt").read_text() == "one" and read_inputs(out)["settings"] == 1
    with replacing(out, {"settings": 2}, "model") as tmp:
        (tmp / "model.pt").write_text("two")
    assert sorted(p.name for p in out.iterdir()) == ["inputs.json", "model.pt"]  # nothing stale
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model"]  # no staging or old copy


def test_claim_refuses_other_settings_unless_overwrite(tmp_path):
    out = tmp_path / "m"
    assert claim(out, "model", {"settings": 1}, overwrite=False) is False
    with replacing(out, {"settings": 1}, "model") as tmp:
        (tmp / "model.pt").write_text("x")
    assert claim(out, "model", {"settings": 1}, overwrite=False) is True
    with pytest.raises(UserError, match=r"other settings \(settings: 1 there, 2 now\).*--overwrite"):
        claim(out, "model", {"settings": 2}, overwrite=False)
    assert claim(out, "model", {"settings": 2}, overwrite=True) is True
    with pytest.raises(UserError, match="holds a report whose settings were not recorded"):
        (tmp_path / "r").mkdir()
        (tmp_path / "r" / "report.html").write_text("old")
        claim(tmp_path / "r", "report", {}, overwrite=False)


def test_paths_are_checked(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(UserError, match="is a file, not a folder"):
        check_folder_target(tmp_path / "f", "--out")
    with pytest.raises(UserError, match="f is a file, not a folder"):
        check_folder_target(tmp_path / "f" / "g" / "h", "--out")
    with pytest.raises(UserError, match="is a folder"):
        check_file_target(tmp_path, "-o")
    assert check_file_target(tmp_path / "new" / "x.json", "-o") == tmp_path / "new" / "x.json"
    assert not (tmp_path / "new").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["f"]
