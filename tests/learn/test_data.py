"""Photo folders as image tables."""

from __future__ import annotations

import pytest
from PIL import Image

from deformsim.errors import UserError
from deformsim.learn.data import expand_images, load_image, real_table

pytestmark = pytest.mark.torch


def photo(path, colour=(200, 30, 30)):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (40, 30), colour).save(path)


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


def test_images_load_as_resized_rgb(tmp_path):
    photo(tmp_path / "x.png", (255, 0, 0))
    x = load_image(tmp_path / "x.png", 64)
    assert x.shape == (3, 64, 64) and x[0].min() == 1 and x[1:].max() == 0
    (tmp_path / "broken.png").write_bytes(b"garbage")
    with pytest.raises(UserError, match="broken.png"):
        load_image(tmp_path / "broken.png", 64)
    assert expand_images([tmp_path]) == [tmp_path / "broken.png", tmp_path / "x.png"]
    with pytest.raises(UserError, match="missing.png"):
        expand_images([tmp_path / "missing.png"])
