"""Variant tables: a composited variant is read only when its manifest is readable and holds the dataset's images."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.variants import has_own_maps, is_current, variant_table
from deformsim.errors import UserError
from tests.fake_dense import make_dense_dataset


@pytest.fixture
def data(tmp_path):
    root = make_dense_dataset(tmp_path / "data", n_samples=4, dense=False)
    composite(root, CompositeConfig(workers=1), "comp", progress=False)
    return root


def _one_error_line(res, *words):
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error:"), res.output
    assert all(w in lines[0] for w in words), lines[0]


def test_a_truncated_variant_manifest_is_one_line_naming_it(data, tmp_path):
    manifest = data / "variants" / "comp" / "manifest.parquet"
    manifest.write_bytes(manifest.read_bytes()[:100])
    for read in (variant_table, has_own_maps):
        with pytest.raises(UserError, match="unreadable") as err:
            read(data, "comp")
        assert str(manifest) in str(err.value)
    assert not is_current(data, "comp")
    res = CliRunner().invoke(app, ["export-data", str(data), str(tmp_path / "x"), "-f", "imagefolder",
                                   "--variant", "comp", "--no-progress"])
    _one_error_line(res, str(manifest))


def test_a_variant_made_before_the_dataset_grew_is_refused_until_composited_again(data):
    assert is_current(data, "comp") and len(variant_table(data, "comp")) == 8
    make_dense_dataset(data, n_samples=6, dense=False)  # the dataset extended: 12 images, the variant still 8
    assert not is_current(data, "comp")
    with pytest.raises(UserError, match="holds 8 images, the dataset 12 .4 of them not in the variant.; rerun "
                                        "deformsim composite .* --name comp"):
        variant_table(data, "comp")
    composite(data, CompositeConfig(workers=1), "comp", progress=False)
    assert is_current(data, "comp") and len(variant_table(data, "comp")) == 12


def test_a_variant_manifest_without_its_columns_is_refused(data):
    manifest = data / "variants" / "comp" / "manifest.parquet"
    pd.read_parquet(manifest).drop(columns=["image"]).to_parquet(manifest)
    with pytest.raises(UserError, match="lacks column.s. image"):
        variant_table(data, "comp")
