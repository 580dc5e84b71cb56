"""Constants and helpers shared by the tests (import as ``tests.util``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"

# The tiny dataset the rendering tests share: 2 scene states (1 intact, 1 deformed) x 4 cameras, 64 px.
TINY = {"generate.n": 8, "render.resolution": 64, "render.samples": 4, "generate.seed": 3}

CARTON_SPEC = ROOT / "examples" / "carton" / "spec.yaml"


def cli(*args: str, **kw) -> subprocess.CompletedProcess:
    """Run ``python -m deformsim.cli ARGS`` from the repository root."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    return subprocess.run([sys.executable, "-m", "deformsim.cli", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=900, **kw)


def dead_tag() -> str:
    """The owner tag (:func:`deformsim.parallel.owner_tag`) of a process that has ended."""
    code = "from deformsim.parallel import owner_tag; print(owner_tag())"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout.strip()


def child_pids(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out
