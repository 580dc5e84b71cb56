"""Dense map files: formats round-trip, boxes, region threshold and per-image statistics."""

from __future__ import annotations

import numpy as np
from PIL import Image

from deformsim.dataset import dense


def test_deform_map_round_trips_in_hundredths_of_a_mm_as_16_bit(tmp_path):
    mm = np.array([[0.0, 0.004, 1.234], [250.0, 700.0, np.nan]])
    dense.save_png(tmp_path / "d.png", dense.encode_u16(mm, dense.DEFORM_SCALE))
    with Image.open(tmp_path / "d.png") as im:
        assert im.mode == "I;16"
    back = dense.read_deform_mm(tmp_path / "d.png")
    assert back.dtype == np.float32
    np.testing.assert_allclose(back, [[0.0, 0.0, 1.23], [250.0, 655.35, 0.0]], atol=1e-4)  # clipped, NaN -> 0


def test_mask_and_bbox_are_exclusive_at_the_far_edge(tmp_path):
    mask = np.zeros((8, 10), bool)
    mask[2:5, 3:7] = True
    dense.save_png(tmp_path / "m.png", dense.mask_image(mask))
    read = dense.read_mask(tmp_path / "m.png")
    assert (read == mask).all()
    assert dense.mask_bbox(read) == (3, 2, 7, 5)
    assert dense.mask_bbox(np.zeros((4, 4), bool)) is None


def test_normals_encode_to_rgb_and_black_off_the_part():
    n = np.zeros((2, 2, 3))
    n[..., 2] = 1.0
    n[0, 0] = (-1.0, 0.0, 0.0)
    mask = np.array([[True, True], [True, False]])
    rgb = dense.encode_normal(n, mask)
    assert rgb[0, 0].tolist() == [0, 128, 128] and rgb[0, 1].tolist() == [128, 128, 255]
    assert rgb[1, 1].tolist() == [0, 0, 0]


def test_region_uses_the_stored_values_and_stats_count_it_against_the_mask():
    deform = np.array([[0.0, 0.996, 1.0], [2.5, 3.0, 0.0]])
    mask = np.array([[True, True, True], [True, False, False]])
    region = dense.region_mask(deform, mask, 1.0)
    assert region.tolist() == [[False, True, True], [True, False, False]]  # 0.996 is stored as 1.00 mm
    stats = dense.map_stats(mask, deform * mask, region)
    assert stats == {"bbox_x0": 0, "bbox_y0": 0, "bbox_x1": 3, "bbox_y1": 2, "visible_disp_mm": 2.5,
                     "region_fraction": 0.75}
    empty = dense.map_stats(np.zeros((2, 2), bool), np.zeros((2, 2)), np.zeros((2, 2), bool))
    assert empty["bbox_x0"] == empty["bbox_y1"] == -1 and empty["region_fraction"] == 0 == empty["visible_disp_mm"]


def test_rigid_fit_removes_rotation_and_translation_but_not_deformation():
    from deformsim.dataset.dense import rigid_fit

    rng = np.random.default_rng(0)
    rest = rng.normal(size=(200, 3))
    angle = 0.7
    rot = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    moved = rest @ rot.T + [0.3, -1.0, 2.0]
    r, t = rigid_fit(rest, moved)
    assert np.abs(rest @ r.T + t - moved).max() < 1e-9  # a rigid motion alone is no deformation
    dent = moved.copy()
    dent[0] += [0.0, 0.0, 0.5]  # one point pushed in by 0.5
    r, t = rigid_fit(rest, dent)
    residual = np.linalg.norm(dent - (rest @ r.T + t), axis=1)
    assert residual[0] == max(residual) and 0.45 < residual[0] <= 0.5 and np.median(residual) < 0.01


def _grid(n: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """A flat n x n grid of unit spacing in z = 0 and its triangles."""
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    co = np.stack([xs.ravel(), ys.ravel(), np.zeros(n * n)], axis=1)
    i = (np.arange(n - 1)[None, :] + n * np.arange(n - 1)[:, None]).ravel()
    tris = np.concatenate([np.stack([i, i + 1, i + n + 1], 1), np.stack([i, i + n + 1, i + n], 1)])
    return co, tris


def test_bend_is_zero_where_the_surface_moves_without_turning_and_peaks_around_a_dent():
    co, tris = _grid()
    np.testing.assert_allclose(dense.vertex_normals(co, tris), np.tile([0.0, 0.0, 1.0], (len(co), 1)), atol=1e-12)
    pushed = co + [0.0, 0.0, -5.0]  # the whole panel pushed straight in: displaced 5, turned by nothing
    assert np.all(dense.bend_deg(co, pushed, tris) < 1e-3)
    dented = co.copy()
    r = np.hypot(co[:, 0] - 4, co[:, 1] - 4)
    dented[:, 2] -= np.where(r < 2, 1 + np.cos(np.pi * r / 2), 0)  # a smooth dent 2 deep at (4, 4)
    bend = dense.bend_deg(co, dented, tris)
    centre, flank, far = (4 * 9 + 4), (4 * 9 + 5), 0
    assert bend[centre] < 1e-3 and bend[far] < 1e-3 and bend[flank] > 30  # the bottom faces up, its flank turns


def test_region_seen_from_the_camera_keeps_movement_across_the_image_or_a_turned_surface():
    deform = np.array([[5.0, 5.0, 5.0, 0.5]])
    mask = np.ones((1, 4), bool)
    across_px = np.array([[0.5, 4.0, 0.5, 3.0]])  # along the line of sight, across the image, along, too small
    turn = np.array([[3.0, 0.0, 20.0, 40.0]])  # hardly turned, not turned, turned, turned but not displaced
    assert dense.region_mask(deform, mask, 1.0).tolist() == [[True, True, True, False]]
    shown = dense.shown(across_px, turn, 2.0, 15.0)
    assert dense.region_mask(deform, mask, 1.0, shown).tolist() == [[False, True, True, False]]


def test_scaled_fit_takes_out_a_change_of_size_along_the_axes_and_keeps_a_bulge():
    rng = np.random.default_rng(1)
    rest = rng.uniform(-1, 1, size=(400, 3))
    angle = 0.4
    rot = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    shorter = (rest * [1.0, 1.0, 0.9]) @ rot.T + [0.5, 0.0, -0.2]  # 10 % shorter, turned and moved: no deformation
    a, t = dense.scaled_fit(rest, shorter)
    np.testing.assert_allclose(rest @ a.T + t, shorter, atol=1e-9)
    r, t = dense.rigid_fit(rest, shorter)
    assert np.abs(rest @ r.T + t - shorter).max() > 0.05  # a rigid fit counts the shortening as displacement
    bulged = rest.copy()
    bulged[:, :2] *= 1 + 0.2 * np.exp(-((rest[:, 2:] - 0.8) / 0.1) ** 2)  # a ring bulged out near the top
    a, t = dense.scaled_fit(rest, bulged)
    left = np.linalg.norm(rest @ a.T + t - bulged, axis=1)
    near = np.abs(rest[:, 2] - 0.8) < 0.05
    assert left[near].mean() > 5 * left[np.abs(rest[:, 2]) < 0.3].mean()


def test_beyond_affine_leaves_nothing_of_a_part_moved_turned_or_resized_as_a_whole_and_keeps_a_local_dent():
    rows, cols = np.mgrid[0:64, 0:64].astype(float)
    mask = (rows - 32) ** 2 + (cols - 32) ** 2 < 24**2  # an end seen from above
    theta, scale = np.radians(4), 1.03  # turned 4 degrees, 3 % larger, moved 5 px right and 3 px down
    x, y = cols - 32, rows - 32
    u = scale * (np.cos(theta) * x - np.sin(theta) * y) - x + 5
    v = scale * (np.sin(theta) * x + np.cos(theta) * y) - y + 3
    assert np.hypot(u, v)[mask].max() > 5  # what the old measure counted
    assert dense.beyond_affine(u, v, mask).max() < 1e-9
    dent = mask & ((rows - 10) ** 2 + (cols - 32) ** 2 < 4**2)  # the rim pushed 6 px inwards at one point
    left = dense.beyond_affine(u, np.where(dent, v + 6, v), mask)
    assert left[dent].min() > 5 and np.median(left[mask & ~dent]) < 0.2
    assert not left[~mask].any()
