"""Dense ground-truth benchmark: seconds per image with ``render.dense`` off and on, and their ratio (target <= 1.25x).

    .venv/bin/python bench/dense.py [--states 4] [--resolution 128] [--samples 16] [--threads 2]

Two workers (dense off, dense on) render the same quick-preset samples in turn, so machine load falls on both
alike; each first renders one warm-up sample that is not counted. Wall time per image includes the state
changes, the renders, PNG writes and, with dense on, the EXR pass read-back and the five maps.
"""

from __future__ import annotations

import argparse

from _util import interleaved_seconds, render_options, run_main

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    render_options(ap)
    a = ap.parse_args()
    spec, hdris = load_spec(None), list_hdris(None)
    settings = {"render.resolution": a.resolution, "render.samples": a.samples}
    cfgs = {on: load_config("quick", {**settings, "render.dense": on}) for on in (False, True)}
    params = [sample_params(i, 0, cfgs[True], spec, hdris) for i in range(a.states + 1)]
    secs, images = interleaved_seconds(cfgs, {on: params for on in cfgs}, a.threads)
    off, on = secs[False], secs[True]
    print(f"{images} images per setting, {a.resolution} px, {a.samples} spp, {a.threads} threads")
    print(f"dense off: {off:.3f} s/image")
    print(f"dense on:  {on:.3f} s/image")
    print(f"ratio:     {on / off:.3f}x (target <= 1.25x)")


if __name__ == "__main__":
    run_main(main)
