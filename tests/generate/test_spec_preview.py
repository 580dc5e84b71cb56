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
    assert "spec preview: 17 tiles (rest, " in proc.stderr  # said before the work starts
    assert "preview tiles: 17/17 (100%)" in proc.stderr  # progress as it renders (stderr is no terminal here)
    sheet = np.asarray(Image.open(out).convert("RGB")).astype(int)
    tile = 64 + max(14, 64 // 8)
    tiles = [sheet[r * tile:r * tile + 64, c * 64:(c + 1) * 64] for r in range(4) for c in range(5)]
    rest, keys = tiles[0], tiles[1:1 + 6 + 2 + 8]  # 6 lattice keys, 2 crinkle textures, 8 simulated bank entries
    assert rest.mean() > 5  # the part is visible
    for k, tile_img in enumerate(keys):
        assert np.abs(tile_img - rest).mean() > 0.3, f"key tile {k} looks like the rest shape"


def test_the_plan_names_the_tiles_and_the_bake_with_its_duration():
    from deformsim.generate.spec_preview import plan_message

    states = [("rest", None), ("dent", None)]
    assert plan_message(states, 0) == "spec preview: 2 tiles (rest, dent)"
    text = plan_message(states, 24)
    assert "baking its 24 scenarios first, about 5 min" in text and "--no-bank" in text


def test_no_bank_renders_the_lattice_keys_alone_and_openings_are_not_deformed(tmp_path):
    from deformsim.generate.spec_preview import DEFORMED_RED, REST_GREY, render_preview
    from deformsim.spec.model import load_spec

    can = load_spec(None)  # the built-in can: lattice keys, textures, tab and seal, and a simulated bank
    assert can.simulation is not None and can.openings.seal
    out = render_preview(None, None, tmp_path / "can.png", 32, 1, bank=False, progress=False)
    sheet = np.asarray(Image.open(out).convert("RGB"))
    tile = 32 + max(14, 32 // 8)
    bars = [tuple(int(v) for v in sheet[r * tile + tile - 1, c * 32 + 16])
            for r in range(sheet.shape[0] // tile) for c in range(5)]
    keys = len(can.key_names) + len(can.texture_names)
    assert bars == [REST_GREY] + [DEFORMED_RED] * keys + [REST_GREY] * 2 + [(255, 255, 255)] * (len(bars) - keys - 3)
