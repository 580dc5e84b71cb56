"""Shared fixtures. Rendering happens in worker subprocesses; the test process never imports bpy."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.util import ROOT, SHARED, TINY


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory) -> Path:
    """A dataset rendered by ``deformsim generate``: 8 images (4 intact, 4 deformed), 64 px."""
    from deformsim.config import load_config
    from deformsim.generate.stage import generate

    out = tmp_path_factory.mktemp("tiny") / "data"
    generate(load_config("quick", TINY), out, progress=False)
    return out


@pytest.fixture
def dent_out_of_view(tiny_dataset, tmp_path) -> tuple[Path, str]:
    """A copy of the tiny dataset in which one deformed image's damage covers 1 % of the part it shows (as if its dent
    faced away from the camera): the dataset and that image's id."""
    import shutil

    import pandas as pd

    from deformsim.dataset.layout import Layout

    data = tmp_path / "dent-out-of-view"
    shutil.copytree(tiny_dataset, data)
    manifest = pd.read_parquet(Layout(data).manifest)
    hidden = manifest.index[manifest["y"] == 1][0]
    manifest.loc[hidden, "region_fraction"] = 0.01
    manifest.to_parquet(Layout(data).manifest)
    return data, manifest.loc[hidden, "id"]


def _shared(name: str) -> Path:
    """A folder of the development data beside the checkout; the test is skipped without it."""
    path = SHARED / name
    if not path.is_dir():
        pytest.skip(f"shared data not found at {path}")
    return path


@pytest.fixture(scope="session")
def backgrounds_dir() -> Path:
    return _shared("backgrounds")


@pytest.fixture(scope="session")
def real_cans_dir() -> Path:
    return _shared("real_cans_dev")


@pytest.fixture(scope="module")
def carton(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("mesh") / "carton.stl"
    subprocess.run([sys.executable, str(ROOT / "examples" / "carton" / "make_carton.py"), str(out)], check=True)
    return out


def pytest_collection_modifyitems(items) -> None:
    """A test that uses the rendered tiny dataset renders: mark it ``blender`` (``-m "not blender"`` skips it)."""
    for item in items:
        if "tiny_dataset" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.blender)
