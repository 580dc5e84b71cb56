"""Bank benchmark: bake time per entry and in total, and generate's seconds per image with the bank vs without.

    .venv/bin/python bench/bake.py [--spec SPEC] [--object MESH] [--states 4] [--fresh]

The bake uses the cached bank unless ``--fresh`` (then it simulates into a temporary cache); the times come
from the bank's own record of each simulation. Two workers then render the same samples in turn, one without
the bank (lattice keys) and one with bank entries (``deform.sources`` bank only), so machine load falls on both
alike; each first renders one warm-up sample that is not counted. Samples are drawn as generate draws them
(half intact). Target: ratio <= 1.3x.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from _util import interleaved_seconds, positive_int, run_main

from deformsim.bank.stage import bake
from deformsim.bank.store import load_bank
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", type=Path, default=None)
    ap.add_argument("--object", type=Path, default=None)
    ap.add_argument("--states", type=positive_int, default=4, help="timed samples (4 images each)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--fresh", action="store_true", help="simulate the bank again in a temporary cache")
    a = ap.parse_args()
    spec = load_spec(a.spec)
    with tempfile.TemporaryDirectory() as tmp:
        if a.fresh:
            os.environ["DEFORMSIM_CACHE"] = str(Path(tmp) / "cache")
        t0 = time.perf_counter()
        path = bake(spec, a.spec, a.object)
        wall = time.perf_counter() - t0
        bank = load_bank(path)
        print(f"bake: {path}{' (fresh)' if a.fresh else ''}, {wall:.1f} s wall in this run")
        for sc in spec.simulation.scenarios:
            secs = [e["stats"]["seconds"] for e in bank.entries if e["name"].startswith(sc.name + "/")]
            print(f"  {sc.name:10s} {sc.kind:15s} {len(secs)} entries, {sum(secs) / len(secs):.1f} s each")
        s = bank.stats()
        print(f"  total {s['entries']} entries, {s['seconds_total']:.0f} s simulated ({s['seconds_per_entry']:.1f} s each)")

        base = {"object.spec": a.spec, "object.mesh": a.object}
        cfgs = {"lattice": load_config("quick", base),
                "bank": load_config("quick", {**base, "deform.sources.lattice": 0, "deform.sources.bank": 1})}
        hdris = list_hdris(None)
        params = {k: [sample_params(i, 0, c, spec, hdris) for i in range(a.states + 1)] for k, c in cfgs.items()}
        secs, images = interleaved_seconds(cfgs, params, a.threads)
    lat, bnk = secs["lattice"], secs["bank"]
    print(f"generate, {images} images each (quick preset): lattice {lat:.3f} s/image, bank {bnk:.3f} s/image, "
          f"ratio {bnk / lat:.3f}x (target <= 1.3x)")


if __name__ == "__main__":
    run_main(main)
