"""Manifest rows: the worker's columns where the reply puts them, none of a feature that is off; resume needs
every image a row names."""

from __future__ import annotations

import json

from deformsim.config import load_config
from deformsim.dataset.layout import DENSE_KINDS, RENDER_KINDS, Layout, image_id
from deformsim.dataset.manifest import image_paths, read_record, rows_for, write_record
from deformsim.dataset.rendered import Rendered
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def _sample():
    cfg = load_config("quick", {"camera.azimuth_quadrants": [(20, 70), (200, 250)]})
    return sample_params(3, 0, cfg, load_spec(None), list_hdris(None))


def _paths(kinds, cam: int) -> dict:
    return {kind: f"images/{kind}/{image_id(3, cam)}.png" for kind in kinds}


def _dense(cam: int) -> dict:
    """An image's columns as the worker's dense feature sends them: the map paths, then the map columns."""
    return {**_paths(DENSE_KINDS, cam), "max_disp_mm": 12.5, "family_crush": 1, "family_pinch": 0, "bbox_x0": cam,
            "bbox_y0": 1, "bbox_x1": 9, "bbox_y1": 8, "visible_disp_mm": 10.0 + cam, "region_fraction": 0.5}


def _write_images(layout: Layout, kinds) -> None:
    for c in range(2):
        for kind in kinds:
            path = layout.image(kind, image_id(3, c))
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"png")


def test_rendered_reply_round_trips_and_a_minimal_reply_reads():
    r = Rendered(3, [1.0, 2.0], DENSE_KINDS, {"rest_tilt": 4.0}, [_dense(0), _dense(1)])
    assert Rendered.from_dict(json.loads(json.dumps(r.to_dict()))) == r
    assert Rendered.from_dict({"done": 3, "render_seconds": [1.0, 2.0]}) == Rendered(3, [1.0, 2.0])


def test_rows_carry_the_image_columns_after_the_timing_in_their_order(tmp_path):
    layout, p = Layout(tmp_path), _sample()
    rows = rows_for(p, layout, Rendered(3, [1.0, 1.0], DENSE_KINDS, image_columns=[_dense(0), _dense(1)]))
    assert rows[1]["mask"] == f"images/mask/{image_id(3, 1)}.png" and rows[1]["region"] == f"images/region/{image_id(3, 1)}.png"
    assert rows[1]["visible_disp_mm"] == 11.0 and rows[0]["bbox_x0"] == 0 and rows[1]["family_crush"] == 1
    keys = list(rows[0])
    assert keys[keys.index("render_seconds") + 1:] == list(_dense(0))
    plain = rows_for(p, layout, Rendered(3, [1.0, 1.0]))
    assert not set(DENSE_KINDS + ("max_disp_mm", "bbox_x0")) & set(plain[0]) and list(plain[0])[-1] == "render_seconds"


def test_sample_columns_follow_the_drawn_pose(tmp_path):
    rows = rows_for(_sample(), Layout(tmp_path), Rendered(3, [1.0, 1.0], sample_columns={"rest_tilt": 4.0}))
    keys = list(rows[0])
    assert keys[keys.index("pose_axis") + 1] == "rest_tilt" and rows[1]["rest_tilt"] == 4.0


def test_a_record_whose_maps_are_missing_is_not_resumed(tmp_path):
    layout, p = Layout(tmp_path), _sample()
    rows = rows_for(p, layout, Rendered(3, [1.0, 1.0], DENSE_KINDS, image_columns=[_dense(0), _dense(1)]))
    assert image_paths(layout, rows[1]) == list(_paths(RENDER_KINDS + DENSE_KINDS, 1).values())
    write_record(layout, p, rows)
    _write_images(layout, RENDER_KINDS + DENSE_KINDS)
    assert read_record(layout, 3) is not None
    layout.image("deform", image_id(3, 1)).unlink()
    assert read_record(layout, 3) is None


def test_framing_columns_only_for_the_options_that_are_on(tmp_path):
    spec, hdris, quads = load_spec(None), list_hdris(None), [(20, 70), (200, 250)]
    plain = rows_for(_sample(), Layout(tmp_path), Rendered(3, [1.0, 1.0]))
    assert not [k for k in plain[0] if k.startswith("cam_") and k not in ("cam_azimuth", "cam_polar", "cam_radius")]
    for extra, cols in [({"camera.fill": [0.5, 0.7]}, {"cam_fill"}),
                        ({"camera.offset": 0.1}, {"cam_shift_x", "cam_shift_y"}),
                        ({"camera.partial": 0.01}, {"cam_cut", "cam_cut_side"}),  # on, though no image is cut
                        ({"camera.lens_mm": [35, 85]}, {"cam_lens"}), ({"camera.fstop": [2, 8]}, {"cam_fstop"})]:
        cfg = load_config("quick", {"camera.azimuth_quadrants": quads, **extra})
        rows = rows_for(sample_params(3, 0, cfg, spec, hdris), Layout(tmp_path), Rendered(3, [1.0, 1.0]))
        assert set(rows[0]) - set(plain[0]) == cols and set(plain[0]) <= set(rows[0])


def test_scene_images_are_needed_for_resume(tmp_path):
    layout, p = Layout(tmp_path), _sample()
    cols = [{**_paths(("shadow", "surface"), c), "surface_params": "{}"} for c in range(2)]
    rows = rows_for(p, layout, Rendered(3, [1.0, 1.0], ("shadow", "surface"), image_columns=cols))
    write_record(layout, p, rows)
    _write_images(layout, RENDER_KINDS + ("shadow", "surface"))
    assert read_record(layout, 3) is not None
    layout.image("surface", image_id(3, 0)).unlink()
    assert read_record(layout, 3) is None


def test_a_pair_column_only_in_paired_datasets(tmp_path):
    cfg = load_config("quick", {"camera.azimuth_quadrants": [(20, 70), (200, 250)], "generate.paired": True})
    rows = rows_for(sample_params(3, 0, cfg, load_spec(None), list_hdris(None)), Layout(tmp_path), Rendered(3, [1.0, 1.0]))
    plain = rows_for(_sample(), Layout(tmp_path), Rendered(3, [1.0, 1.0]))
    assert [r["pair"] for r in rows] == [2, 2] and set(rows[0]) - set(plain[0]) == {"pair"}
    assert rows[0]["label"] == "intact" and "pair" not in plain[0]
