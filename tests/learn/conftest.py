"""Shared fixtures: an easy synthetic image set (round vs jagged blobs) and an isolated weights cache."""

from __future__ import annotations

import pandas as pd
import pytest

from tests.learn.blobs import make_blobs


@pytest.fixture(scope="session", autouse=True)
def learn_cache(tmp_path_factory):
    """Converted weights and feature caches go to a per-session folder, not ~/.cache."""
    mp = pytest.MonkeyPatch()
    path = tmp_path_factory.mktemp("deformsim-cache")
    mp.setenv("DEFORMSIM_CACHE", str(path))
    yield path
    mp.undo()


@pytest.fixture(scope="session")
def blobs(tmp_path_factory) -> pd.DataFrame:
    """40 + 40 easy images at 64 px in intact/ and deformed/ folders."""
    return make_blobs(tmp_path_factory.mktemp("blobs"), 40)
