"""Appearance and shape benchmark: seconds per image with render.appearance and object.shapes off and on, and ratios.

    .venv/bin/python bench/appearance.py [--states 4] [--resolution 128] [--samples 16] [--threads 2] [--photos DIR]

One worker per setting (today's default, ``render.appearance: {}``, ``object.shapes: {}``, both) renders the same
quick-preset samples in turn (each config's own draws of the same indices), so machine load falls on all alike;
each first renders one warm-up sample that is not counted. Wall time per image includes the label designer (numpy
and PIL, once per sample), the shape map of every shape key and the renders. ``--photos`` adds artwork photos.
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
    ap.add_argument("--photos", default=None, help="folder of artwork photos for render.appearance.photos")
    a = ap.parse_args()
    spec, hdris = load_spec(None), list_hdris(None)
    look = {"photos": a.photos} if a.photos else {}
    settings = {"today": {}, "appearance": {"render.appearance": look}, "shapes": {"object.shapes": {}},
                "both": {"render.appearance": look, "object.shapes": {}}}
    base = {"render.resolution": a.resolution, "render.samples": a.samples}
    cfgs = {name: load_config("quick", {**base, **extra}) for name, extra in settings.items()}
    params = {name: [sample_params(i, 0, c, spec, hdris) for i in range(a.states + 1)] for name, c in cfgs.items()}
    secs, images = interleaved_seconds(cfgs, params, a.threads)
    print(f"{images} images per setting, {a.resolution} px, {a.samples} spp, {a.threads} threads")
    for name, s in secs.items():
        print(f"{name:11s} {s:.3f} s/image  {s / secs['today']:.2f}x")


if __name__ == "__main__":
    run_main(main)
