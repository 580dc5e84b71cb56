"""Dense ground truth from the worker: zero on intact parts, the rig's displacement on deformed ones, masks = alpha."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset import dense
from deformsim.dataset.layout import DENSE_KINDS, Layout, image_id
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

CAMERAS = [(20, 70), (200, 250)]
CRINKLE = {"crinkle_coarse": 1.0}  # broad bumps: finer crinkle peaks are narrower than a 64 px pixel


def _config(dense_on: bool, **more):
    return load_config("quick", {**TINY_RENDER, "camera.azimuth_quadrants": CAMERAS, "render.dense": dense_on, **more})


def _render(root, name: str, cfg, samples) -> tuple[Layout, list[dict]]:
    layout = Layout(root / name)
    w = WorkerProcess(root / f"{name}.log", threads=2)
    try:
        w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(layout.root)})
        replies = [w.render(p.to_dict()) for p in samples]
    finally:
        w.close()
    assert all("done" in r for r in replies), replies
    return layout, replies


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Deformed D (lattice), the same sample intact I (openings kept), crinkle-only C; with dense on, then off."""
    cfg = _config(True)
    spec = load_spec(None)
    d = sample_params(0, 5, cfg, spec, list_hdris(None))
    zero_keys, zero_disp = dict.fromkeys(d.keys, 0.0), dict.fromkeys(d.displacement, 0.0)
    d = dataclasses.replace(d, keys={**zero_keys, "crush_top": 0.3, "fold_x": 0.4}, displacement=zero_disp,
                            families=("crush", "fold"), seal=0.6, tab=0.9)
    i = dataclasses.replace(d, index=1, label="intact", families=(), keys=zero_keys)
    c = dataclasses.replace(d, index=2, keys=zero_keys, displacement={**zero_disp, **CRINKLE}, families=("crunch",))
    root = tmp_path_factory.mktemp("dense")
    from_above = tuple(dataclasses.replace(cam, polar=3.0) for cam in d.cameras)
    crushed = dataclasses.replace(d, index=3, keys={**zero_keys, "crush_top": 0.5}, families=("crush",), cameras=from_above)
    tilted = dataclasses.replace(d, index=4, keys={**zero_keys, "fold_x": 0.2}, families=("fold",), cameras=from_above,
                                 pose_tilt=0.0)
    on, on_replies = _render(root, "on", cfg, [d, i, c, crushed])
    off, off_replies = _render(root, "off", _config(False), [d, i])
    visible, visible_replies = _render(root, "visible", _config(True, **{"render.region_visible": {}}), [d, crushed])
    sharp = {"render.resolution": 192}  # the lid moves a few mm: at 64 px, under 2 px
    fitted, _ = _render(root, "fitted", _config(True, **sharp, **{"render.region_visible": {"view_fit": True}}),
                        [tilted])
    unfitted, _ = _render(root, "unfitted", _config(True, **sharp, **{"render.region_visible": {}}), [tilted])
    return {"on": on, "off": off, "visible": visible, "fitted": fitted, "unfitted": unfitted, "replies": on_replies,
            "off_replies": off_replies, "visible_replies": visible_replies, "samples": (d, i, c)}


def _maps(layout: Layout, index: int, cam: int) -> dict:
    iid = image_id(index, cam)
    return {
        "alpha": np.array(Image.open(layout.image("rgba", iid)))[..., 3],
        "mask": dense.read_mask(layout.image("mask", iid)),
        "deform": dense.read_deform_mm(layout.image("deform", iid)),
        "region": dense.read_mask(layout.image("region", iid)),
        "depth": dense.read_depth_mm(layout.image("depth", iid)),
        "normal": np.array(Image.open(layout.image("normal", iid))).astype(float) / 255 * 2 - 1,
    }


def test_rgb_images_are_byte_identical_with_dense_on_or_off(runs):
    for index in (0, 1):
        for cam in range(len(CAMERAS)):
            for kind in ("rgba", "black", "green"):
                iid = image_id(index, cam)
                assert runs["on"].image(kind, iid).read_bytes() == runs["off"].image(kind, iid).read_bytes(), (kind, iid)
    assert not (runs["off"].root / "images" / "mask").exists() and runs["off_replies"][0]["kinds"] == []


def test_masks_match_alpha_and_maps_are_well_formed(runs):
    for index in range(3):
        for cam in range(len(CAMERAS)):
            m = _maps(runs["on"], index, cam)
            alpha = m["alpha"] >= 128
            assert (m["mask"] & alpha).sum() / (m["mask"] | alpha).sum() >= 0.99
            radius_mm = runs["samples"][index].cameras[cam].radius * 1000
            assert np.all(np.abs(m["depth"][m["mask"]] - radius_mm) < 150)  # the can lies around the aim point
            assert np.all(m["depth"][~m["mask"]] == 0) and np.all(m["deform"][~m["mask"]] == 0)
            # camera space, z towards the viewer: visible surfaces face the camera
            assert m["normal"][m["mask"]][:, 2].mean() > 0.5
            row = runs["replies"][index]["image_columns"][cam]
            assert (row["bbox_x0"], row["bbox_y0"], row["bbox_x1"], row["bbox_y1"]) == dense.mask_bbox(m["mask"])


def test_intact_part_gives_zero_maps_despite_open_tab_and_seal(runs):
    rows = runs["replies"][1]["image_columns"]
    assert all(r["max_disp_mm"] == 0 and r["visible_disp_mm"] == 0 and r["region_fraction"] == 0 for r in rows)
    for cam in range(len(CAMERAS)):
        m = _maps(runs["on"], 1, cam)
        assert m["mask"].sum() > 100 and not m["deform"].any() and not m["region"].any()


def test_deformed_maps_are_positive_where_the_rig_moved_and_peak_at_the_vertex_maximum(runs):
    rows = runs["replies"][0]["image_columns"]
    peak = rows[0]["max_disp_mm"]
    assert peak > 10 and all(r["max_disp_mm"] == peak for r in rows)
    assert rows[0]["family_crush"] == 1 and rows[0]["family_pinch"] == 0
    visible = [r["visible_disp_mm"] for r in rows]
    assert abs(max(visible) - peak) <= 0.1 * peak
    for cam in range(len(CAMERAS)):
        m = _maps(runs["on"], 0, cam)
        assert (m["deform"][m["mask"]] > 0).mean() > 0.9  # the lattice moves the whole can
        assert m["region"].sum() == (m["mask"] & (m["deform"] >= 1.0)).sum() > 0


def test_crinkle_map_peaks_at_the_shape_key_displacement_computed_in_numpy(runs):
    expected = run_blender(f"""
        import json
        import numpy as np
        from deformsim.blender import cycles
        from deformsim.blender.part import can
        from deformsim.blender.motion.rig import build_rig
        from deformsim.spec.model import load_spec
        from deformsim.dataset.dense import rigid_fit
        cycles.reset()
        obj = can.build_can()
        spec = load_spec(None)
        build_rig(obj, spec)
        keys = obj.data.shape_keys.key_blocks
        def co(block):
            a = np.empty(len(block.data) * 3, np.float32)
            block.data.foreach_get("co", a)
            return a.reshape(-1, 3).astype(float)
        rest = co(keys["Basis"])
        for name, value in ((spec.openings.seal, 0.6), (spec.openings.tab, 0.9)):
            rest = rest + value * (co(keys[name]) - co(keys[name].relative_key))
        moved = rest + sum(v * (co(keys[k]) - co(keys["Basis"])) for k, v in {CRINKLE!r}.items())
        r, t = rigid_fit(rest, moved)
        print(json.dumps({{"max_mm": float(np.linalg.norm(moved - (rest @ r.T + t), axis=1).max() * 1000)}}))
    """)["max_mm"]
    rows = runs["replies"][2]["image_columns"]
    assert expected > 1 and rows[0]["max_disp_mm"] == pytest.approx(expected, rel=1e-3)
    visible = max(r["visible_disp_mm"] for r in rows)
    assert abs(visible - expected) <= 0.1 * expected
    for cam in range(len(CAMERAS)):
        m = _maps(runs["on"], 2, cam)
        assert (m["region"] & ~m["mask"]).sum() == 0 and 0 < m["region"].sum() < m["mask"].sum()


def test_every_dense_kind_is_written(runs):
    for kind in DENSE_KINDS:
        assert runs["on"].image(kind, image_id(0, 0)).is_file()


def test_the_visible_region_keeps_the_renders_and_leaves_out_what_moved_along_the_line_of_sight(runs):
    for index in (0, 3):
        for cam in range(len(CAMERAS)):
            iid = image_id(index, cam)
            assert runs["visible"].image("rgba", iid).read_bytes() == runs["on"].image("rgba", iid).read_bytes()
            m = _maps(runs["visible"], index, cam)
            assert not (m["region"] & ~(m["mask"] & (m["deform"] >= 1.0))).any()  # displaced, and showing it
            row = runs["visible_replies"][index // 3]["image_columns"][cam]
            assert row["region_fraction"] == pytest.approx(m["region"].sum() / m["mask"].sum())
    for cam in range(len(CAMERAS)):
        # crushed from the top, seen from above: the can got shorter (a size, not a deformation) and its lid moved
        # along the line of sight without turning; only the bulge under the lid may show
        everything, visible = (_maps(runs[k], 3, cam)["region"].sum() for k in ("on", "visible"))
        assert visible < 0.5 * everything
        # crushed and folded, seen from the side: the fold shows
        assert _maps(runs["visible"], 0, cam)["region"].sum() > 0.3 * _maps(runs["on"], 0, cam)["region"].sum()


def test_a_lid_tilted_as_a_whole_seen_from_above_is_no_visible_region(runs):
    # folded by 15 degrees at mid height, upright: from above the lid moved sideways and tilted as a whole, as an
    # intact can placed a little differently would look; only the wall showing past the rim may count
    for cam in range(len(CAMERAS)):
        every_move, beyond_fit = (_maps(runs[k], 4, cam)["region"].sum() for k in ("unfitted", "fitted"))
        assert every_move > 0.1 * _maps(runs["fitted"], 4, cam)["mask"].sum()
        assert beyond_fit < 0.5 * every_move
