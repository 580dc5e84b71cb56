"""Worker memory over a long run: resident memory of one Blender worker rendering 300+ tiny images.

Prints RSS after the first sample and after the last, and their ratio, with and without purging/recycling
(`generate.recycle_every`): the orchestrator restarts a worker every K images so memory stays bounded.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from _util import rss_mb

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.generate.backend import worker_setup
from deformsim.generate.stage import prepare
from deformsim.generate.worker_client import WorkerProcess
from deformsim.sampling import sample_params

IMAGES = 320
RECYCLE = 100


def run(recycle_every: int) -> tuple[float, float, float, float]:
    cfg = load_config("quick", {"generate.n": IMAGES, "render.resolution": 32, "render.samples": 1,
                                "render.denoise": False, "generate.recycle_every": recycle_every})
    with tempfile.TemporaryDirectory() as tmp:
        spec, hdris = prepare(cfg, Path(tmp))
        layout = Layout(Path(tmp))
        worker, rendered, first, peak = None, 0, None, 0.0
        t0 = time.perf_counter()
        for i in range(IMAGES // 4):
            if worker is None or rendered >= recycle_every:
                if worker is not None:
                    worker.close()
                worker = WorkerProcess(log_path=Path(tmp) / "w.log", threads=2)
                worker.start(worker_setup(cfg, layout))
                rendered = 0
            reply = worker.render(sample_params(i, 0, cfg, spec, hdris).to_dict())
            assert "done" in reply, reply
            rendered += 4
            rss = rss_mb(worker.pid)
            first = first or rss
            peak = max(peak, rss)
        end = rss_mb(worker.pid)
        worker.close()
        return first, end, peak, time.perf_counter() - t0


if __name__ == "__main__":
    for label, k in (("no recycling", 10**9), (f"recycle every {RECYCLE}", RECYCLE)):
        first, end, peak, secs = run(k)
        print(f"{label:>20}: {IMAGES} images in {secs:.0f} s; RSS start {first:.0f} MiB, end {end:.0f} MiB, "
              f"peak {peak:.0f} MiB, end/start ratio {end / first:.3f}")
