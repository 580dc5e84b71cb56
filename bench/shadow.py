"""Shadow benchmark: seconds per image with ``render.shadow`` off and on, and their ratio.

    .venv/bin/python bench/shadow.py [--states 4] [--resolution 128] [--samples 16] [--threads 2]

Two workers (shadow off, shadow on) render the same quick-preset samples in turn, so machine load falls on both
alike; each first renders one warm-up sample that is not counted. Wall time per image includes the state
changes, the renders, PNG writes and, with shadow on, the shadow-catcher pass per camera and the fresh Cycles
session after it (blender.shadow). Dense maps are off in both (``--dense`` turns them on in both).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from deformsim.config import load_config  # noqa: E402
from deformsim.generate.worker_client import WorkerProcess  # noqa: E402
from deformsim.hdri import list_hdris  # noqa: E402
from deformsim.sampling import sample_params  # noqa: E402
from deformsim.spec.model import load_spec  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=4, help="timed samples (4 images each)")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--dense", action="store_true", help="dense maps on in both workers (the quick preset's setting)")
    a = ap.parse_args()
    spec, hdris = load_spec(None), list_hdris(None)
    settings = {"render.resolution": a.resolution, "render.samples": a.samples, "render.dense": a.dense}
    cfgs = {on: load_config("quick", {**settings, "render.shadow": on}) for on in (False, True)}
    params = [sample_params(i, 0, cfgs[True], spec, hdris) for i in range(a.states + 1)]
    wall = {False: 0.0, True: 0.0}
    images = 0
    with tempfile.TemporaryDirectory() as tmp:
        workers = {on: WorkerProcess(Path(tmp) / f"shadow-{on}.log", threads=a.threads) for on in (False, True)}
        try:
            for on, w in workers.items():
                w.start({"config": cfgs[on].model_dump(mode="json"), "spec_path": None, "out": f"{tmp}/{on}"})
            for k, p in enumerate(params):
                for on, w in workers.items():
                    t0 = time.perf_counter()
                    reply = w.render(p.to_dict())
                    if "error" in reply:
                        raise SystemExit(f"sample {p.index} failed: {reply['message']}")
                    if k:  # sample 0 warms both workers up
                        wall[on] += time.perf_counter() - t0
                images += len(p.cameras) if k else 0
        finally:
            for w in workers.values():
                w.close()
    off, on = wall[False] / images, wall[True] / images
    print(f"{images} images per setting, {a.resolution} px, {a.samples} spp, {a.threads} threads, dense {a.dense}")
    print(f"shadow off: {off:.3f} s/image")
    print(f"shadow on:  {on:.3f} s/image")
    print(f"ratio:      {on / off:.3f}x")


if __name__ == "__main__":
    main()
