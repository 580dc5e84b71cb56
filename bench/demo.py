"""Wall time of `deformsim run` (what `make demo` runs) per stage, from an empty run folder; then the learning
stages again on the same renders with the paper's single VGG-16 (the quick preset's model before 2026-12-07), and
their ratio."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from _util import SHARED

from deformsim.config import load_config
from deformsim.pipeline import run

if __name__ == "__main__":
    backgrounds = SHARED / "backgrounds"
    real = SHARED / "real_cans_dev" if (SHARED / "real_cans_dev").is_dir() else None
    given = {"composite.backgrounds": backgrounds if backgrounds.is_dir() else None}
    cfg = load_config("quick", given)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run(cfg, Path(tmp) / "demo", real=real, progress=False)
        total = time.perf_counter() - t0
        for stage, secs in result.seconds.items():
            print(f"{stage:<24} {secs:7.1f} s")
        print(f"{'total':<24} {total:7.1f} s (target: under 600 s)")
        t0 = time.perf_counter()
        again = run(cfg, Path(tmp) / "demo", real=real, progress=False)
        print(f"rerun with nothing changed: {time.perf_counter() - t0:.1f} s, skipped {', '.join(again.skipped)}")
        single = load_config("quick", {**given, "train.ensemble": 1, "train.ensemble_backbones": []})
        one = run(single, Path(tmp) / "demo", real=real, progress=False)
        learn = {k: v for k, v in result.seconds.items() if k not in one.skipped}
        print(f"the same with one VGG-16: {', '.join(f'{k} {v:.1f} s' for k, v in one.seconds.items())}; the "
              f"default's {', '.join(learn)} took {sum(learn.values()) / sum(one.seconds.values()):.2f}x as long")
