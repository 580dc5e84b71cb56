"""Seconds and peak memory of `deformsim adapt` on N unlabelled photos, in a fresh process with an empty feature cache.

    python bench/adapt_time.py MODEL [--n 100] [--photos DIR ...] [--method fixmatch --data DATASET]

The photos are the first N distinct images of the folders (default: ../shared/data's real cans, real tins and
backgrounds), copied flat into a temporary folder. The time holds reading the model, the photos' pass through every
backbone's frozen and trained layers, the probe's fit (or, with a method that trains the networks, the renders of
``--data`` and the photos' augmented views through the frozen layers and the training) and the saved model (target:
3 minutes for 100 photos on 2 cores, #54).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _util import ROOT, SHARED, positive_int, run_main


def _child(model: str, photos: str, out: str, method: str, data: str) -> None:
    import resource
    import time

    from deformsim import Engine
    from deformsim.learn.adapter import AdaptRecipe

    t0 = time.perf_counter()
    Engine(progress=False).adapt(model, photos, out, AdaptRecipe(method=method), data=data or None)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    print(json.dumps({"seconds": seconds, "peak_mib": peak}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", type=Path)
    ap.add_argument("--n", type=positive_int, default=100)
    ap.add_argument("--photos", type=Path, nargs="+",
                    default=[SHARED / "real_cans_dev", SHARED / "real_tins_dev", SHARED / "backgrounds"])
    ap.add_argument("--method", default="probe", help="deformsim adapt's --method")
    ap.add_argument("--data", type=Path, help="the model's dataset, for the methods that train the networks")
    args = ap.parse_args()
    from deformsim.dataset.real import expand_images
    from deformsim.identity import file_digest

    seen, chosen = set(), []
    for path in expand_images(args.photos):
        if (d := file_digest(path)) not in seen and len(chosen) < args.n:
            seen.add(d)
            chosen.append(Path(path))
    if len(chosen) < args.n:
        raise SystemExit(f"error: {len(chosen)} distinct photos in {', '.join(map(str, args.photos))}, --n {args.n}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "photos").mkdir()
        for i, path in enumerate(chosen):
            shutil.copy(path, tmp / "photos" / f"{i:04d}{path.suffix.lower()}")
        env = {**os.environ, "DEFORMSIM_CACHE": str(tmp / "cache"), "PYTHONPATH": str(ROOT / "src")}
        from deformsim.outputs import cache_dir

        if (cache_dir() / "weights").is_dir():  # converted weights are not the adaptation's work: keep them
            shutil.copytree(cache_dir() / "weights", tmp / "cache" / "weights")
        data = str(args.data.resolve()) if args.data else ""
        done = subprocess.run([sys.executable, __file__, "--child", str(args.model), str(tmp / "photos"),
                               str(tmp / "out"), args.method, data], env=env, capture_output=True, text=True, cwd=ROOT)
        if done.returncode:
            raise SystemExit(f"error: adapt failed:\n{done.stderr[-2000:]}")
        result = json.loads(done.stdout.strip().splitlines()[-1])
    print(f"adapt {args.model} ({args.method}) on {args.n} photos: {result['seconds']:.1f} s, peak memory "
          f"{result['peak_mib']:.0f} MiB (target: 180 s)")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        _child(*sys.argv[2:7])
    else:
        run_main(main)
