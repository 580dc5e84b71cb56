"""Render benchmark: seconds per image at 256 and 512 px, and the worker's overhead over Cycles' own time.

    .venv/bin/python bench/render.py [--samples 16] [--states 4] [--threads 0]

Each resolution uses a fresh worker; the wall time of a sample (state changes, 4 renders, PNG writes)
is divided by its images, and compared with the sum of Cycles' render-call seconds.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from _util import positive_int, run_main

from deformsim.config import load_config
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def bench(resolution: int, samples: int, states: int, threads: int, out: Path) -> dict:
    cfg = load_config("quick", {"render.resolution": resolution, "render.samples": samples, "render.denoise": True})
    spec, hdris = load_spec(None), list_hdris(None)
    w = WorkerProcess(out / f"bench{resolution}.log", threads=threads)
    t0 = time.perf_counter()
    ready = w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(out / str(resolution))})
    setup = time.perf_counter() - t0
    wall, cycles, images = 0.0, 0.0, 0
    try:
        for i in range(states):
            p = sample_params(i, 0, cfg, spec, hdris)
            t0 = time.perf_counter()
            reply = w.render(p.to_dict())
            wall += time.perf_counter() - t0
            if "error" in reply:
                raise SystemExit(f"sample {i} failed: {reply['message']}")
            cycles += sum(reply["render_seconds"])
            images += len(reply["render_seconds"])
    finally:
        w.close()
    return {"res": resolution, "images": images, "setup": setup, "wall": wall / images, "cycles": cycles / images,
            "device": ready["device"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=positive_int, default=16, help="Cycles samples per pixel (denoised)")
    ap.add_argument("--states", type=positive_int, default=4, help="scene states (x4 cameras) at 256 px; 1 at 512 px")
    ap.add_argument("--threads", type=int, default=0, help="Cycles threads (0 = all cores)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="deformsim-bench-") as tmp:
        rows = [bench(256, args.samples, args.states, args.threads, Path(tmp)),
                bench(512, args.samples, 1, args.threads, Path(tmp))]
    print(f"device: {rows[0]['device']}, {args.samples} spp + OpenImageDenoise")
    print(f"{'px':>4} {'images':>6} {'setup s':>8} {'s/image':>8} {'cycles s/image':>15} {'overhead':>9}")
    for r in rows:
        print(f"{r['res']:>4} {r['images']:>6} {r['setup']:>8.2f} {r['wall']:>8.2f} {r['cycles']:>15.2f} "
              f"{r['wall'] / r['cycles']:>9.3f}")


if __name__ == "__main__":
    run_main(main)
