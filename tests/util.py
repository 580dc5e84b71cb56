"""Constants and helpers shared by the tests (import as ``tests.util``)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"

# The tiny dataset the rendering tests share: 2 scene states (1 intact, 1 deformed) x 4 cameras, 64 px.
TINY = {"generate.n": 8, "render.resolution": 64, "render.samples": 4, "generate.seed": 3}
