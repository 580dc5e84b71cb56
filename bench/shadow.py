"""Shadow benchmark: seconds per image with ``render.shadow`` off and on, and their ratio.

    .venv/bin/python bench/shadow.py [--states 4] [--resolution 128] [--samples 16] [--threads 2]

Two workers (shadow off, shadow on) render the same quick-preset samples in turn, so machine load falls on both
alike; each first renders one warm-up sample that is not counted. Wall time per image includes the state
changes, the renders, PNG writes and, with shadow on, the shadow-catcher pass per camera and the fresh Cycles
session after it (blender.shadow). Dense maps are off in both (``--dense`` turns them on in both).
"""

from __future__ import annotations

import argparse

from _util import interleaved_seconds

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


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
    secs, images = interleaved_seconds(cfgs, {on: params for on in cfgs}, a.threads)
    off, on = secs[False], secs[True]
    print(f"{images} images per setting, {a.resolution} px, {a.samples} spp, {a.threads} threads, dense {a.dense}")
    print(f"shadow off: {off:.3f} s/image")
    print(f"shadow on:  {on:.3f} s/image")
    print(f"ratio:      {on / off:.3f}x")


if __name__ == "__main__":
    main()
