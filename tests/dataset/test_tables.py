"""Training tables: where they come from and the checks that refuse one before any work."""

from __future__ import annotations

import pandas as pd
import pytest

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
