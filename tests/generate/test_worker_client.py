"""The bpy-free worker client: crash and timeout detection, setup errors."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from deformsim.config import load_config
from deformsim.generate.worker_client import WorkerCrashed, WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def _setup(tmp_path, **overrides):
    cfg = load_config("quick", {"render.resolution": 64, "render.samples": 4, **overrides})
    return cfg, {"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(tmp_path / "out")}


@pytest.mark.blender
def test_sigkill_during_render_raises_worker_crashed(tmp_path):
    cfg, setup = _setup(tmp_path, **{"render.resolution": 256, "render.samples": 256})
    params = sample_params(0, 0, cfg, load_spec(None), list_hdris(None)).to_dict()
    w = WorkerProcess(tmp_path / "w.log", threads=1)
    ready = w.start(setup, timeout=120)
    assert ready["pid"] == w.pid
    threading.Timer(1.0, os.kill, (w.pid, signal.SIGKILL)).start()
    t0 = time.monotonic()
    with pytest.raises(WorkerCrashed, match="-9"):
        w.render(params, timeout=120)
    assert time.monotonic() - t0 < 30
    with pytest.raises(WorkerCrashed):  # and it stays dead
        w.render(params, timeout=5)


@pytest.mark.blender
def test_render_timeout_kills_worker(tmp_path):
    cfg, setup = _setup(tmp_path, **{"render.resolution": 256, "render.samples": 256})
    params = sample_params(0, 0, cfg, load_spec(None), list_hdris(None)).to_dict()
    w = WorkerProcess(tmp_path / "w.log", threads=1)
    w.start(setup, timeout=120)
    with pytest.raises(WorkerCrashed, match="did not answer"):
        w.render(params, timeout=0.5)
    assert w.proc.poll() is not None


@pytest.mark.blender
def test_setup_error_names_the_problem(tmp_path):
    _, setup = _setup(tmp_path)
    w = WorkerProcess(tmp_path / "w.log")
    with pytest.raises(WorkerCrashed, match="nowhere.yaml"):
        w.start({**setup, "spec_path": str(tmp_path / "nowhere.yaml")}, timeout=120)
    assert "nowhere.yaml" in (tmp_path / "w.log").read_text()
