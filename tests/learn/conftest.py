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


@pytest.fixture(scope="module")
def trained(blobs, tmp_path_factory):
    """A tiny model trained on the blobs (32 px, one epoch, offline weights)."""
    from deformsim.config import TrainConfig
    from deformsim.learn.train import fit

    cfg = TrainConfig(weights="offline", image_size=32, epochs=1, batch_size=16)
    return fit(blobs, cfg, tmp_path_factory.mktemp("model") / "m", progress=False).model_path


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """'Real' photos in intact/ and deformed/: other blobs (another seed)."""
    root = tmp_path_factory.mktemp("photos") / "real"
    return root, make_blobs(root, 6, seed=11)
