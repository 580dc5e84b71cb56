"""Throughput of the quick and paper presets on this machine, and the paper preset's extrapolated wall time.

    .venv/bin/python bench/throughput.py [--backgrounds DIR] [--out runs/throughput] [--small 8] [--large 40]

For each preset: render images per hour with 1 and 2 workers, composite seconds per 1000 images, and the learning
stage (``deformsim report``: features, the four trainings of Table II, PCA; no real folder) per 1000 images, with an
empty feature cache. Each rate is a difference of two runs (``--small`` and ``--large`` images), so the one-off
costs (worker start, scene build, model build) cancel; they are printed apart. The paper preset renders 512 px
images and trains at 224 px; its learning stage is measured on its own renders. Extrapolation to the paper's 6000
images adds render, composite and learning time (rendering with the given number of workers).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from _util import SHARED

PAPER_N = 6000


def timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def measure(preset: str, n: int, workers: int, root: Path, backgrounds: Path | None, learn: bool) -> dict:
    """Seconds to render, composite and (optionally) learn on ``n`` fresh images of ``preset``."""
    from deformsim import Engine

    engine = Engine(preset, {"generate.n": n, "generate.workers": workers, "train.variants": ["black", "backgrounds"]})
    data = root / f"{preset}-{n}-w{workers}"
    out = {"render": timed(lambda: engine.generate(data))}
    out["composite"] = timed(lambda: engine.composite(data, "backgrounds", backgrounds=backgrounds))
    if learn:
        cache = root / f"cache-{preset}-{n}"
        shutil.copytree(root / "cache", cache)  # converted weights, no features: every image goes through the stem
        os.environ["DEFORMSIM_CACHE"] = str(cache)
        out["learn"] = timed(lambda: engine.report(data, data / "report"))
    return out


def rate(small: dict, large: dict, n_small: int, n_large: int, key: str) -> tuple[float, float]:
    """(seconds per image at steady state, one-off seconds) from two runs of different size."""
    per = (large[key] - small[key]) / (n_large - n_small)
    return per, small[key] - per * n_small


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backgrounds", type=Path, default=SHARED / "backgrounds" if (SHARED / "backgrounds").is_dir() else None)
    ap.add_argument("--out", type=Path, default=Path("runs/throughput"))
    ap.add_argument("--small", type=int, default=8, help="images in the small run (a multiple of 8)")
    ap.add_argument("--large", type=int, default=40, help="images in the large run")
    args = ap.parse_args()
    from deformsim.config import load_config
    from deformsim.learn.weights import resolve

    results = {}
    with tempfile.TemporaryDirectory(prefix="deformsim-throughput-") as tmp:
        root = Path(tmp)
        os.environ["DEFORMSIM_CACHE"] = str(root / "cache")
        for preset in ("quick", "paper"):
            train = load_config(preset).train
            resolve(train.backbone, train.weights)  # convert the offline weights once, outside the timings
        for preset in ("quick", "paper"):
            row = {}
            for workers in (1, 2):
                runs = {n: measure(preset, n, workers, root, args.backgrounds, learn=workers == 2)
                        for n in (args.small, args.large)}
                small, large = runs[args.small], runs[args.large]
                per, once = rate(small, large, args.small, args.large, "render")
                row[f"render_w{workers}"] = {"seconds_per_image": per, "once": once, "images_per_hour": 3600 / per}
                if workers == 2:
                    for key in ("composite", "learn"):
                        per, once = rate(small, large, args.small, args.large, key)
                        row[key] = {"seconds_per_1000": 1000 * per, "once": once}
                print(f"{preset} w{workers}: {json.dumps(runs)}", flush=True)
            fixed = row["composite"]["seconds_per_1000"] * PAPER_N / 1000 + row["learn"]["seconds_per_1000"] * PAPER_N / 1000
            row["paper_scale_hours"] = {w: (PAPER_N * row[f"render_w{w}"]["seconds_per_image"] + fixed) / 3600 for w in (1, 2)}
            results[preset] = row
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "throughput.json").write_text(json.dumps(results, indent=1))
    print(f"\n{'preset':<7} {'render img/h 1w':>16} {'2w':>7} {'composite s/1000':>17} {'learning s/1000':>16} "
          f"{PAPER_N} images: {'1w h':>6} {'2w h':>6}")
    for preset, r in results.items():
        print(f"{preset:<7} {r['render_w1']['images_per_hour']:>16.0f} {r['render_w2']['images_per_hour']:>7.0f} "
              f"{r['composite']['seconds_per_1000']:>17.0f} {r['learn']['seconds_per_1000']:>16.0f} "
              f"{'':>12}{r['paper_scale_hours'][1]:>6.2f} {r['paper_scale_hours'][2]:>6.2f}")
    print(f"one-off seconds (worker start, model build) are in {args.out / 'throughput.json'}")


if __name__ == "__main__":
    main()
