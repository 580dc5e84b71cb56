"""Training tables: where they come from and the checks that refuse one before any work."""

from __future__ import annotations

import pandas as pd
import pytest

from deformsim.config import load_config
from deformsim.dataset.tables import check_table, load_table
from deformsim.errors import UserError
from tests.fake_dense import make_dense_dataset


def test_a_dataset_of_one_class_is_refused_naming_the_variant_and_the_counts(tmp_path):
    data = make_dense_dataset(tmp_path / "data", n_samples=2, dense=False)
    manifest = pd.read_parquet(data / "manifest.parquet")
    manifest[manifest["y"] == 0].to_parquet(data / "manifest.parquet", index=False)
    with pytest.raises(UserError, match=f"variant 'black' of {data} has 2 intact and 0 deformed images: training "
                                        "needs both classes"):
        load_table(data, "black", "green")
    table = load_table(make_dense_dataset(tmp_path / "both", n_samples=2, dense=False), None, "green")
    assert sorted(table["y"]) == [0, 0, 1, 1]
    with pytest.raises(UserError, match="the image table has 0 intact and 2 deformed"):
        check_table(table[table["y"] == 1])


def test_min_region_leaves_out_deformed_images_whose_damage_is_out_of_view(tmp_path):
    data = make_dense_dataset(tmp_path / "data", n_samples=4)
    manifest = pd.read_parquet(data / "manifest.parquet")
    unseen = manifest.index[(manifest["y"] == 1)][:1]
    manifest.loc[unseen, "region_fraction"] = 0.01  # one deformed view whose dent faces away
    manifest.to_parquet(data / "manifest.parquet", index=False)
    kept = load_table(data, "black", "green", min_region=0.02)
    assert set(manifest["id"]) - set(kept["id"]) == set(manifest.loc[unseen, "id"])
    assert len(load_table(data, "black", "green")) == len(manifest)  # 0 keeps every image
    with pytest.raises(UserError, match="train.min_region 0.02 needs the deformed region.*render.dense"):
        load_table(make_dense_dataset(tmp_path / "flat", n_samples=2, dense=False), "black", "green", min_region=0.02)


def test_min_region_without_dense_renders_is_refused_before_any_work():
    with pytest.raises(UserError, match="train.min_region=0.02 needs render.dense: true"):
        load_config("quick", {"render.dense": False, "train.min_region": 0.02})
    assert load_config("quick", {"train.min_region": 0.02}).train.min_region == 0.02  # the quick preset renders dense
