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
