"""Scene benchmark: seconds per image with shadows and rendered surfaces off and on, and their ratios.

    .venv/bin/python bench/scene.py [--states 4] [--resolution 128] [--samples 16] [--threads 2]

One worker per setting (none, ``render.shadow``, ``render.surface``, both) renders the same quick-preset samples
in turn, so machine load falls on all alike; each first renders one warm-up sample that is not counted. Wall time
per image includes the state changes, the renders, PNG writes and the extra passes per camera (shadow catcher,
surface scene) with the fresh Cycles session after them (blender.scene.ground). Dense maps are off in all (``--dense``
turns them on in all).
"""

from __future__ import annotations

import argparse

from _util import interleaved_seconds, render_options, run_main

from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec

SETTINGS = {"none": {}, "shadow": {"render.shadow": True}, "surface": {"render.surface": {}},
            "shadow + surface": {"render.shadow": True, "render.surface": {}}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    render_options(ap)
    ap.add_argument("--dense", action="store_true", help="dense maps on in every worker (the quick preset's setting)")
    a = ap.parse_args()
    spec, hdris = load_spec(None), list_hdris(None)
    base = {"render.resolution": a.resolution, "render.samples": a.samples, "render.dense": a.dense}
    cfgs = {name: load_config("quick", {**base, **extra}) for name, extra in SETTINGS.items()}
    params = [sample_params(i, 0, cfgs["shadow + surface"], spec, hdris) for i in range(a.states + 1)]
    secs, images = interleaved_seconds(cfgs, {name: params for name in cfgs}, a.threads)
    print(f"{images} images per setting, {a.resolution} px, {a.samples} spp, {a.threads} threads, dense {a.dense}")
    for name, s in secs.items():
        print(f"{name:17s} {s:.3f} s/image  {s / secs['none']:.2f}x")


if __name__ == "__main__":
    run_main(main)
