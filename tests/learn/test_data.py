"""Photo folders as image tables."""

from __future__ import annotations

import pytest
import torch
from PIL import Image

from deformsim.dataset.real import expand_images
from deformsim.errors import UserError
from deformsim.learn.data import RandomConv, load_image

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


def test_random_convolution_keeps_the_shape_and_changes_texture_and_colour():
    x = torch.full((3, 48, 48), 0.2)
    x[:, 12:36, 18:30] = torch.tensor([0.9, 0.6, 0.1])[:, None, None]  # an orange bar on grey
    before = x.clone()
    torch.manual_seed(0)
    outs = [RandomConv(1.0)(x) for _ in range(20)]
    torch.manual_seed(0)
    assert all(torch.equal(a, RandomConv(1.0)(x)) for a in outs)  # one seed, the same draws
    assert all(o.shape == x.shape and o.min() >= 0 and o.max() <= 1 for o in outs)
    changed = [o for o in outs if (o - x).abs().max() > 0.05]
    assert len(changed) >= 15
    inside = x[:, 20:28, 21:27]
    for o in changed:  # the bar still stands apart from the ground, at the same place
        assert (o[:, 20:28, 21:27].mean((1, 2)) - o[:, 2:8, 2:8].mean((1, 2))).abs().max() > 0.05
    colours = torch.stack([o[:, 20:28, 21:27].mean((1, 2)) for o in changed])
    assert colours.std(0).min() > 0.05 and (colours - inside.mean((1, 2))).abs().max() > 0.2
    assert torch.equal(RandomConv(0.0)(x), x) and torch.equal(x, before)  # off: as it was; the input never changes
