"""The bpy-free worker client: HDRI listing, crash and timeout detection, setup errors."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from deformsim.config import load_config
from deformsim.errors import UserError
from deformsim.sampling import sample_params
from deformsim.spec import load_spec
from deformsim.worker_client import WorkerCrashed, WorkerProcess, list_hdris

STUDIO_LIGHTS = ["city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"]


def test_list_hdris_default_is_blenders_studio_lights():
    assert list_hdris(None) == STUDIO_LIGHTS


def test_list_hdris_user_folder(tmp_path):
    for name in ("b.HDR", "a.exr", "notes.txt"):
        (tmp_path / name).write_bytes(b"x")
    assert list_hdris(tmp_path) == ["a", "b"]


@pytest.mark.parametrize("make", ["missing", "empty", "duplicate"])
def test_list_hdris_bad_folder_is_user_error(tmp_path, make):
    folder = tmp_path / "hdris"
    if make != "missing":
        folder.mkdir()
    if make == "duplicate":
        (folder / "sky.exr").write_bytes(b"x")
        (folder / "sky.hdr").write_bytes(b"x")
    with pytest.raises(UserError, match="hdris"):
        list_hdris(folder)


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
