"""Folders of real photos as labelled image tables (no torch)."""

from __future__ import annotations

import pytest

from deformsim.dataset.real import real_table
from deformsim.errors import UserError
from tests.learn.test_data import photo


@pytest.mark.parametrize("good,bad", [("intact", "deformed"), ("good", "defect")])
def test_real_table(tmp_path, good, bad):
    photo(tmp_path / good / "a.jpg")
    photo(tmp_path / good / "sub" / "b.png")
    photo(tmp_path / bad / "c.JPG")
    (tmp_path / bad / "notes.txt").write_text("not an image")
    t = real_table(tmp_path)
    assert list(t["label"]) == ["intact", "intact", "deformed"] and list(t["y"]) == [0, 0, 1]
    assert list(t["id"]) == ["intact/a", "intact/sub/b", "deformed/c"]
    assert all(p.startswith("/") for p in t["path"])


def test_real_table_errors(tmp_path):
    with pytest.raises(UserError, match="not found"):
        real_table(tmp_path / "nope")
    photo(tmp_path / "intact" / "a.jpg")
    with pytest.raises(UserError, match="deformed/ or defect/"):
        real_table(tmp_path)
    (tmp_path / "deformed").mkdir()
    with pytest.raises(UserError, match="holds no images"):
        real_table(tmp_path)
