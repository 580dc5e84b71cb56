"""`deformsim spec preview`: one tile per key and bank entry, each visibly different from the rest shape."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from tests.util import CARTON_SPEC, cli

pytestmark = pytest.mark.blender


def test_spec_preview_shows_each_key(tmp_path, carton):
    out = tmp_path / "keys.png"
    proc = cli("spec", "preview", str(CARTON_SPEC), "--object", str(carton), "--out", str(out),
               "--resolution", "64", "--samples", "2")
    assert proc.returncode == 0, proc.stderr[-2000:]
    sheet = np.asarray(Image.open(out).convert("RGB")).astype(int)
    tile = 64 + max(14, 64 // 8)
    tiles = [sheet[r * tile:r * tile + 64, c * 64:(c + 1) * 64] for r in range(4) for c in range(5)]
    rest, keys = tiles[0], tiles[1:1 + 6 + 2 + 8]  # 6 lattice keys, 2 crinkle textures, 8 simulated bank entries
    assert rest.mean() > 5  # the part is visible
    for k, tile_img in enumerate(keys):
        assert np.abs(tile_img - rest).mean() > 0.3, f"key tile {k} looks like the rest shape"
