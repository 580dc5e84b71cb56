"""A hostile manifest: an ``id`` or ``label`` that names a path, and path columns that leave the dataset, refused
with one line before anything is written (the export and the variant stay inside their folders)."""

from __future__ import annotations

import pandas as pd
import pytest

from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.errors import UserError
from deformsim.export import export_data
from tests.fake_dense import make_dense_dataset


@pytest.fixture
def data(tmp_path):
    return make_dense_dataset(tmp_path / "data", n_samples=2, cameras=2, size=32)


def _edit(data, col, value, row=0):
    path = data / "manifest.parquet"
    df = pd.read_parquet(path)
    if isinstance(value, int):  # a column holds one type: all its values numbers
        df[col] = range(len(df))
    else:
        df[col] = df[col].astype(object)
        df.loc[row, col] = value
    df.to_parquet(path, index=False)


@pytest.mark.parametrize("fmt", ["imagefolder", "coco", "anomalib"])
def test_an_id_naming_a_path_is_refused_by_export(data, tmp_path, fmt):
    victim = tmp_path / "victim2.png"
    victim.write_bytes(b"mine")
    _edit(data, "id", "../../../victim2")
    out = tmp_path / "exp" / "a" / "b"
    with pytest.raises(UserError, match=r"row 0.*id.*'\.\./\.\./\.\./victim2'.*not a plain file name") as err:
        export_data(data, out, fmt, variant="black", progress=False)
    assert "\n" not in str(err.value)
    assert victim.read_bytes() == b"mine" and not out.exists()


@pytest.mark.parametrize("value", ["/abs/victim", "a/b", "..", ".", "", "x\x00y", "a\\b", 5, None])
def test_every_unsafe_id_is_refused_by_composite(data, tmp_path, value):
    if value == "/abs/victim":
        value = str(tmp_path / "victim")
    _edit(data, "id", value)
    with pytest.raises(UserError, match="row 0.*id") as err:
        composite(data, CompositeConfig(workers=1), "bg", progress=False)
    assert "\n" not in str(err.value)
    assert not (tmp_path / "victim.png").exists()
    assert not (data / "variants").exists() or not any((data / "variants").iterdir())


def test_repeated_ids_are_refused(data, tmp_path):
    path = data / "manifest.parquet"
    df = pd.read_parquet(path)
    pd.concat([df, df.iloc[:1]]).to_parquet(path, index=False)
    with pytest.raises(UserError, match="id '000000_c0' more than once"):
        export_data(data, tmp_path / "exp", "imagefolder", variant="black", progress=False)


@pytest.mark.parametrize("fmt", ["imagefolder", "coco"])
def test_a_label_that_is_no_class_is_refused(data, tmp_path, fmt):
    """imagefolder made a folder of the label (``../x``); coco looked it up (KeyError on ``<script>``)."""
    for label in ("<script>alert(1)</script>", "../../outside"):
        _edit(data, "label", label)
        with pytest.raises(UserError, match="row 0.*label.*intact or deformed") as err:
            export_data(data, tmp_path / "exp", fmt, variant="black", progress=False)
        assert "\n" not in str(err.value)
    assert not (tmp_path / "outside").exists() and not (tmp_path / "exp").exists()


def test_a_label_that_contradicts_y_is_refused(data, tmp_path):
    _edit(data, "label", "deformed", row=0)  # row 0 is intact (y 0)
    with pytest.raises(UserError, match="row 0.*label 'deformed'.*y 0"):
        export_data(data, tmp_path / "exp", "imagefolder", variant="black", progress=False)


@pytest.mark.parametrize("col", ["rgba", "green"])
def test_composite_never_reads_a_render_outside_the_dataset(data, tmp_path, col):
    """Its sources were joined to the dataset's folder unchecked: an absolute path read any PNG."""
    secret = tmp_path / "secret.png"
    secret.write_bytes((data / "images" / "rgba" / "000000_c0.png").read_bytes())
    _edit(data, col, str(secret))
    with pytest.raises(UserError, match="outside the dataset"):
        composite(data, CompositeConfig(workers=1, matte="alpha" if col == "rgba" else "chroma"), "bg", progress=False)



@pytest.mark.parametrize("col, values", [("region_fraction", [[1.0, 2.0]] * 4), ("id", list(range(4)))])
def test_a_variant_manifest_column_of_another_type_is_one_line(data, tmp_path, col, values):
    """A list in a composited variant's column reached the export (TypeError); ids that are numbers a merge."""
    composite(data, CompositeConfig(workers=1), "bg", progress=False)
    path = data / "variants" / "bg" / "manifest.parquet"
    pd.read_parquet(path).assign(**{col: values}).to_parquet(path, index=False)
    with pytest.raises(UserError, match=rf"variant manifest {path} (column {col} holds values|row 0 \(id\))") as err:
        export_data(data, tmp_path / "exp", "coco", variant="bg", progress=False)
    assert "\n" not in str(err.value)
