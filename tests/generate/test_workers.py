"""How many render workers `generate` starts by itself: one per 4 cores, at least one, one on a GPU."""

from __future__ import annotations

import pytest

from deformsim.config import load_config
from deformsim.generate.backend import render_workers


@pytest.mark.parametrize(("cores", "workers"), [(1, 1), (2, 1), (4, 1), (8, 2), (16, 4)])
def test_one_worker_per_four_cores(monkeypatch, cores, workers):
    monkeypatch.setattr("os.cpu_count", lambda: cores)
    assert render_workers(load_config("quick", {}), 1000) == workers


def test_a_gpu_gets_one_worker_and_a_set_count_is_kept_up_to_the_samples(monkeypatch):
    monkeypatch.setattr("os.cpu_count", lambda: 16)
    assert render_workers(load_config("quick", {"render.device": "gpu"}), 1000) == 1
    assert render_workers(load_config("quick", {"generate.workers": 3}), 1000) == 3
    assert render_workers(load_config("quick", {"generate.workers": 3}), 2) == 2
    assert render_workers(load_config("quick", {}), 1) == 1
