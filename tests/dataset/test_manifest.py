"""Manifest rows: dense-map columns and paths when the worker sent them, none otherwise; resume needs the maps."""

from __future__ import annotations

import json

from deformsim.config import load_config
from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout, image_id
from deformsim.dataset.manifest import read_record, rows_for, write_record
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def _sample():
    cfg = load_config("quick", {"camera.azimuth_quadrants": [(20, 70), (200, 250)]})
    return sample_params(3, 0, cfg, load_spec(None), list_hdris(None))


def _dense(cam: int) -> dict:
    return {"max_disp_mm": 12.5, "family_crush": 1, "family_pinch": 0, "bbox_x0": cam, "bbox_y0": 1, "bbox_x1": 9,
            "bbox_y1": 8, "visible_disp_mm": 10.0 + cam, "region_fraction": 0.5}


def test_rows_carry_dense_columns_and_map_paths(tmp_path):
    layout, p = Layout(tmp_path), _sample()
    rows = rows_for(p, layout, [1.0, 1.0], dense=[_dense(0), _dense(1)])
    assert rows[1]["mask"] == f"images/mask/{image_id(3, 1)}.png" and rows[1]["region"] == f"images/region/{image_id(3, 1)}.png"
    assert rows[1]["visible_disp_mm"] == 11.0 and rows[0]["bbox_x0"] == 0 and rows[1]["family_crush"] == 1
    plain = rows_for(p, layout, [1.0, 1.0])
    assert not set(DENSE_KINDS + ("max_disp_mm", "bbox_x0")) & set(plain[0])


def test_a_record_whose_maps_are_missing_is_not_resumed(tmp_path):
    layout, p = Layout(tmp_path), _sample()
    rows = rows_for(p, layout, [1.0, 1.0], dense=[_dense(0), _dense(1)])
    write_record(layout, p, rows)
    for c in range(2):
        for kind in RENDER_KINDS + DENSE_KINDS:
            path = layout.image(kind, image_id(3, c))
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"png")
    assert read_record(layout, 3) is not None
    layout.image("deform", image_id(3, 1)).unlink()
    assert read_record(layout, 3) is None


def test_framing_columns_only_for_the_options_that_are_on(tmp_path):
    spec, hdris, quads = load_spec(None), list_hdris(None), [(20, 70), (200, 250)]
    plain = rows_for(_sample(), Layout(tmp_path), [1.0, 1.0])
    assert not [k for k in plain[0] if k.startswith("cam_") and k not in ("cam_azimuth", "cam_polar", "cam_radius")]
    for extra, cols in [({"camera.fill": [0.5, 0.7]}, {"cam_fill"}),
                        ({"camera.offset": 0.1}, {"cam_shift_x", "cam_shift_y"}),
                        ({"camera.partial": 0.01}, {"cam_cut", "cam_cut_side"}),  # on, though no image is cut
                        ({"camera.lens_mm": [35, 85]}, {"cam_lens"}), ({"camera.fstop": [2, 8]}, {"cam_fstop"})]:
        cfg = load_config("quick", {"camera.azimuth_quadrants": quads, **extra})
        rows = rows_for(sample_params(3, 0, cfg, spec, hdris), Layout(tmp_path), [1.0, 1.0])
        assert set(rows[0]) - set(plain[0]) == cols and set(plain[0]) <= set(rows[0])


def test_scene_images_and_the_drawn_surface_are_recorded_and_needed_for_resume(tmp_path):
    cfg = load_config("quick", {"camera.azimuth_quadrants": [(20, 70), (200, 250)], "render.surface": {}})
    layout, p = Layout(tmp_path), sample_params(3, 0, cfg, load_spec(None), list_hdris(None))
    rows = rows_for(p, layout, [1.0, 1.0], scene=("shadow", "surface"))
    assert rows[1]["surface"] == f"images/surface/{image_id(3, 1)}.png" and rows[0]["shadow"].startswith("images/shadow/")
    assert json.loads(rows[0]["surface_params"])["kind"] == p.surface.kind
    assert "surface_params" not in rows_for(_sample(), layout, [1.0, 1.0])[0]
    write_record(layout, p, rows)
    for c in range(2):
        for kind in RENDER_KINDS + ("shadow", "surface"):
            path = layout.image(kind, image_id(3, c))
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"png")
    assert read_record(layout, 3) is not None
    layout.image("surface", image_id(3, 0)).unlink()
    assert read_record(layout, 3) is None
