"""Dense maps through compositing: they move exactly like the part (framing, flip) and stay aligned with the picture."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest

from deformsim.composite.framing import warp
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.dense import mask_bbox, read_deform_mm, read_mask
from deformsim.dataset.variants import variant_table
from deformsim.errors import UserError
from tests.fake_dense import PART_RGB, make_dense_dataset


@pytest.fixture
def dense(tmp_path):
    return make_dense_dataset(tmp_path / "data")


def _run(root, name, **cfg):
    variant = composite(root, CompositeConfig(matte="alpha", workers=1, **cfg), name, seed=4, progress=False).folder
    return variant, pd.read_parquet(variant / "manifest.parquet").set_index("id")


def _maps(root, rel):
    return read_mask(root / rel["mask"]), read_deform_mm(root / rel["deform"]), read_mask(root / rel["region"])


def _part_pixels(picture_path):
    """Where the composite shows the part's flat colour."""
    rgb = cv2.cvtColor(cv2.imread(str(picture_path)), cv2.COLOR_BGR2RGB).astype(int)
    return np.abs(rgb - np.array(PART_RGB)).max(axis=-1) <= 2


def test_flipped_composite_has_flipped_maps(dense):
    _, plain = _run(dense, "plain")
    _, flipped = _run(dense, "flipped", flip_part=1.0)
    manifest = pd.read_parquet(dense / "manifest.parquet").set_index("id")
    assert not plain["part_flip"].any() and flipped["part_flip"].all()
    for iid, row in manifest.iterrows():
        render = _maps(dense, row)
        for got, want in zip(_maps(dense, plain.loc[iid]), render):
            assert np.array_equal(got, want)
        for got, want in zip(_maps(dense, flipped.loc[iid]), render):
            assert np.array_equal(got, want[:, ::-1])
        # the map lines up with the picture: the part's pixels are exactly the flipped mask
        assert np.array_equal(_part_pixels(dense / flipped.loc[iid, "image"]), render[0][:, ::-1])
    # the flip has its own generator: the backgrounds did not change
    assert plain["background"].equals(flipped["background"])


def test_flip_probability_is_seeded_and_partial(dense):
    _, a = _run(dense, "a", flip_part=0.5)
    _, b = _run(dense, "b", flip_part=0.5)
    assert a["part_flip"].equals(b["part_flip"]) and 0 < a["part_flip"].sum() < len(a)


def test_framed_maps_follow_the_crop_and_keep_their_values(dense):
    _, framed = _run(dense, "framed", object_fill=(0.8, 0.8), fill_offset=0.1)
    manifest = pd.read_parquet(dense / "manifest.parquet").set_index("id")
    for iid, row in framed.iterrows():
        mask, deform, region = _maps(dense, row)
        render_mask, render_deform, _ = _maps(dense, manifest.loc[iid])
        side, x, y = row["frame_side"], row["frame_x"], row["frame_y"]
        h, w = render_mask.shape
        m = np.array([[w / side, 0, -x * w / side], [0, h / side, -y * h / side]], np.float32)
        assert np.array_equal(mask, warp(render_mask.astype(np.uint8), m, nearest=True) > 0)
        assert set(np.unique(deform)) <= set(np.unique(render_deform))  # nearest: no blended values
        assert (mask_bbox(mask) is None) == (row["bbox_x0"] == -1)
        if mask.any():
            bx0, by0, bx1, by1 = mask_bbox(mask)
            assert (row["bbox_x0"], row["bbox_y0"], row["bbox_x1"], row["bbox_y1"]) == (bx0, by0, bx1, by1)
            assert max(bx1 - bx0, by1 - by0) / w == pytest.approx(0.8, abs=0.05)
            inner = cv2.erode(mask.astype(np.uint8), np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0
            assert _part_pixels(dense / row["image"])[inner].all()  # the picture shows the part where the map says
        assert row["visible_disp_mm"] == pytest.approx(float(deform[mask].max()) if mask.any() else 0.0)
        assert row["region_fraction"] == pytest.approx(region.sum() / mask.sum() if mask.any() else 0.0)
        assert not (region & ~mask).any()


def test_variant_table_takes_the_variant_maps(dense):
    _run(dense, "framed", object_fill=(0.7, 0.9))
    composited, black = variant_table(dense, "framed"), variant_table(dense, "black")
    assert composited["mask"].str.startswith(f"{dense}/variants/framed/mask/").all()
    assert black["mask"].str.startswith(f"{dense}/images/mask/").all()
    assert {"bbox_x0", "visible_disp_mm", "region_fraction", "max_disp_mm", "family_crush"} <= set(composited.columns)


def test_missing_map_is_named_before_work(dense):
    victim = dense / "images" / "deform" / "000001_c1.png"
    victim.unlink()
    with pytest.raises(UserError, match="000001_c1.png"):
        _run(dense, "x")
    assert not (dense / "variants" / "x").exists()


def test_dataset_without_maps_gets_no_map_columns(tmp_path):
    root = make_dense_dataset(tmp_path / "plain", dense=False)
    variant, df = _run(root, "v", flip_part=1.0)
    assert not {"mask", "deform", "region"} & set(df.columns) and df["part_flip"].all()
    assert not (variant / "mask").exists()
