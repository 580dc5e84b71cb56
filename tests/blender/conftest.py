"""Blender test helpers: snippets run in a fresh worker-like subprocess; the test process never imports bpy."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # lets test modules import this helper as tests.blender.conftest under plain pytest
    sys.path.insert(0, str(ROOT))
PYTHON = ROOT / ".venv" / "bin" / "python"

TINY_RENDER = {"render.resolution": 64, "render.samples": 4, "render.threads": 2}


def run_blender(code: str, timeout: float = 300) -> dict:
    """Run ``code`` in a fresh Python with bpy (PYTHONPATH=src); return the JSON printed on its last line."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    python = str(PYTHON if PYTHON.exists() else sys.executable)
    proc = subprocess.run(
        [python, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env, timeout=timeout
    )
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        raise AssertionError(f"blender snippet failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return json.loads(lines[-1])


def worker_renders(log: Path, cfg, out: Path, params: list) -> list[dict]:
    """Render ``params`` (SampleParams) in turn with one worker set up for ``cfg`` writing to ``out``; the replies."""
    from deformsim.generate.worker_client import WorkerProcess

    w = WorkerProcess(log, threads=2)
    try:
        w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(out)})
        return [w.render(p.to_dict()) for p in params]
    finally:
        w.close()


def assert_same_but_colour(replies: list[list[dict]], roots: list[Path], samples: int, cameras: int,
                           kinds: tuple[str, ...]) -> list[tuple]:
    """Two renders of the same samples (each one's worker ``replies`` and output root): the same manifest columns (all
    but the timings) and the same bytes of every image of ``kinds`` and of the alpha. Returns each image's two RGBA
    arrays, for the caller's checks of the colour."""
    import numpy as np
    from PIL import Image

    from deformsim.dataset.layout import Layout, image_id

    timings = {"render_seconds", "seconds"}
    first, second = ([{k: v for k, v in r.items() if k not in timings} for r in rs] for rs in replies)
    assert first == second  # labels, bounding boxes, region shares, displacements
    layouts, pairs = [Layout(r) for r in roots], []
    for sample in range(samples):
        for c in range(cameras):
            iid = image_id(sample, c)
            for kind in kinds:
                assert layouts[0].image(kind, iid).read_bytes() == layouts[1].image(kind, iid).read_bytes(), (kind, iid)
            a, b = (np.array(Image.open(layout.image("rgba", iid))) for layout in layouts)
            assert np.array_equal(a[..., 3], b[..., 3]), iid
            pairs.append((iid, a, b))
    return pairs


@pytest.fixture(scope="session")
def tiny_config():
    from deformsim.config import load_config

    return load_config("quick", TINY_RENDER)


@pytest.fixture(scope="session")
def python_exe() -> str:
    return str(PYTHON if PYTHON.exists() else sys.executable)
