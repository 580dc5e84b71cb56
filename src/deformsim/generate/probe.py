"""The mesh probe: import a user's mesh in a throwaway Blender process before any work starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from deformsim.errors import UserError
from deformsim.extras import require
from deformsim.generate.worker_client import worker_env


def probe_mesh(mesh: Path, spec_path: Path | None, timeout: float = 300) -> dict:
    """Import ``mesh`` in a throwaway Blender process; its size, or a UserError naming the problem."""
    require("render", what="reading a mesh")
    args = [sys.executable, "-m", "deformsim.blender.part.mesh_import", str(mesh)] + ([str(spec_path)] if spec_path else [])
    proc = subprocess.run(args, capture_output=True, text=True, env=worker_env(), timeout=timeout)
    if proc.returncode == 2:
        raise UserError(proc.stderr.strip().splitlines()[-1])
    if proc.returncode != 0:
        raise RuntimeError(f"mesh probe failed ({proc.returncode}): {' '.join(proc.stderr.split()[-60:])}")
    return json.loads(proc.stdout.strip().splitlines()[-1])
