"""Photo folders as image tables."""

from __future__ import annotations

import pytest
from PIL import Image

from deformsim.dataset.real import expand_images
from deformsim.errors import UserError
from deformsim.learn.data import load_image

pytestmark = pytest.mark.torch


def photo(path, colour=(200, 30, 30)):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (40, 30), colour).save(path)


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
