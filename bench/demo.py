"""Wall time of `deformsim run` (what `make demo` runs) per stage, from an empty run folder."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from _util import SHARED

from deformsim.config import load_config
from deformsim.pipeline import run

if __name__ == "__main__":
    backgrounds = SHARED / "backgrounds"
    real = SHARED / "real_cans_dev"
    cfg = load_config("quick", {"composite.backgrounds": backgrounds if backgrounds.is_dir() else None})
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run(cfg, Path(tmp) / "demo", real=real if real.is_dir() else None, progress=False)
        total = time.perf_counter() - t0
        for stage, secs in result.seconds.items():
            print(f"{stage:<24} {secs:7.1f} s")
        print(f"{'total':<24} {total:7.1f} s (target: under 600 s)")
        t0 = time.perf_counter()
        again = run(cfg, Path(tmp) / "demo", real=real if real.is_dir() else None, progress=False)
        print(f"rerun with nothing changed: {time.perf_counter() - t0:.1f} s, skipped {', '.join(again.skipped)}")
