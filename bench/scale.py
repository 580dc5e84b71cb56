"""Throughput of local workers: images per second with 1 and 2 worker processes, and their ratio."""

from __future__ import annotations

import tempfile
import time

from _util import ROOT  # noqa: F401  (puts src on the path)

from deformsim.config import load_config
from deformsim.generate.stage import generate

N, RES, SAMPLES = 32, 96, 8


def rate(workers: int) -> float:
    cfg = load_config("quick", {"generate.n": N, "render.resolution": RES, "render.samples": SAMPLES,
                                "generate.workers": workers, "generate.preview": 0})
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        generate(cfg, f"{tmp}/out", progress=False)
        return N / (time.perf_counter() - t0)


if __name__ == "__main__":
    one, two = rate(1), rate(2)
    print(f"{N} images at {RES} px, {SAMPLES} spp: 1 worker {one:.2f} img/s, 2 workers {two:.2f} img/s, "
          f"ratio 2/1 = {two / one:.2f}")
