"""`deformsim spec preview`: one tile per key and bank entry, each visibly different from the rest shape."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from deformsim.generate.spec_preview import SHEET_TILE
from tests.util import CARTON_SPEC, cli


@pytest.mark.blender
def test_spec_preview_shows_each_key(tmp_path, carton):
    out = tmp_path / "keys.png"
    proc = cli("spec", "preview", str(CARTON_SPEC), "--object", str(carton), "--out", str(out),
               "--resolution", "64", "--samples", "2")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "spec preview: 17 tiles (rest, " in proc.stderr  # said before the work starts
    sheet = np.asarray(Image.open(out).convert("RGB")).astype(int)
    side = SHEET_TILE  # 64 px renders, shown at 128 so that their captions read whole
    tile = side + max(14, side // 8)
    tiles = [sheet[r * tile:r * tile + side, c * side:(c + 1) * side] for r in range(4) for c in range(5)]
    rest, keys = tiles[0], tiles[1:1 + 6 + 2 + 8]  # 6 lattice keys, 2 crinkle textures, 8 simulated bank entries
    assert rest.mean() > 5  # the part is visible
    for k, tile_img in enumerate(keys):
        assert np.abs(tile_img - rest).mean() > 0.3, f"key tile {k} looks like the rest shape"


def test_the_plan_names_the_tiles_their_time_and_the_bake_with_its_duration():
    from deformsim.config import load_config
    from deformsim.generate.refusals import render_seconds
    from deformsim.generate.spec_preview import WORKER_START_S, plan_message

    states = [("rest", None), ("dent", None)]
    assert plan_message(states, 0, 5.0) == "spec preview: 2 tiles (rest, dent), about 20 s on 2 cores"
    assert plan_message(states * 30, 0, 5.0).endswith("60 tiles (" + ", ".join(["rest, dent"] * 30) + "), about 5 min "
                                                       "on 2 cores")
    text = plan_message(states, 24, 5.0)
    assert "baking its 24 scenarios first, about 5 min" in text and "--no-bank" in text
    cfg = load_config("quick", {"render.resolution": 192, "render.samples": 16})
    assert render_seconds(cfg) > render_seconds(load_config("quick", {"render.resolution": 64}))
    assert WORKER_START_S + 17 * render_seconds(cfg) < 600  # the default preview of the can: minutes, not hours


def test_every_caption_reads_whole_at_the_sheets_tile_size():
    from deformsim.dataset.contact_sheet import MIN_FONT, caption
    from deformsim.spec.model import load_spec
    from deformsim.spec.simulation import entry_names

    for spec in (load_spec(None), load_spec(CARTON_SPEC)):
        for name in ["tab + seal open", *spec.key_names, *spec.texture_names, *entry_names(spec.simulation)]:
            shown, font = caption(name, SHEET_TILE - 8, max(8, max(14, SHEET_TILE // 8) - 6))
            assert shown == name and font.getlength(name) <= SHEET_TILE - 8  # was "squashed_midd" at 64 px
    shown, font = caption("a_caption_far_too_long_for_any_tile_of_this_sheet", 60, 8)
    assert shown.startswith("a_") and shown.endswith("heet") and "…" in shown and font.size == MIN_FONT
    assert font.getlength(shown) <= 60


@pytest.mark.blender
def test_no_bank_renders_the_lattice_keys_alone_and_openings_are_not_deformed(tmp_path):
    from deformsim.generate.spec_preview import DEFORMED_RED, REST_GREY, render_preview
    from deformsim.spec.model import load_spec

    can = load_spec(None)  # the built-in can: lattice keys, textures, tab and seal, and a simulated bank
    assert can.simulation is not None and can.openings.seal
    out = render_preview(None, None, tmp_path / "can.png", 32, 1, bank=False, progress=False)
    sheet = np.asarray(Image.open(out).convert("RGB"))
    side = SHEET_TILE
    tile = side + max(14, side // 8)
    bars = [tuple(int(v) for v in sheet[r * tile + tile - 1, c * side + side // 2])
            for r in range(sheet.shape[0] // tile) for c in range(5)]
    keys = len(can.key_names) + len(can.texture_names)
    assert bars == [REST_GREY] + [DEFORMED_RED] * keys + [REST_GREY] * 2 + [(255, 255, 255)] * (len(bars) - keys - 3)
