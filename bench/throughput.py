"""Throughput of the quick and paper presets on this machine, and the paper preset's extrapolated wall time.

    .venv/bin/python bench/throughput.py [--backgrounds DIR] [--out runs/throughput]

Every rate is the difference of two runs of different size, so one-off costs (worker start, scene build, model
build, weight loading) cancel; they are printed apart. Per preset: render images per hour with 1 and 2 workers
(``--render-sizes``), composite seconds per 1000 images, and the learning stage (``deformsim report``: features,
the four trainings of Table II, PCA, the dense heads; no real folder; an empty feature cache) per 1000 images on
``--learn-sizes`` quick-preset renders with the preset's training settings (learning time depends on the model's
input size, not on the render's). Extrapolation to the paper's 6000 images adds render, composite and learning time.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from _util import SHARED, positive_int, run_main

PAPER_N = 6000
PRESETS = ("quick", "paper")


def timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def rate(seconds: dict[int, float]) -> dict:
    """Seconds per image at steady state and the one-off seconds, from runs of two sizes."""
    (n0, t0), (n1, t1) = sorted(seconds.items())
    per = (t1 - t0) / (n1 - n0)
    return {"seconds_per_image": per, "once": t0 - per * n0, "runs": {str(n): t for n, t in seconds.items()}}


def render_rates(preset: str, sizes: list[int], root: Path) -> dict:
    from deformsim import Engine

    out = {}
    for workers in (1, 2):
        seconds = {}
        for n in sizes:
            engine, data = Engine(preset, {"generate.n": n, "generate.workers": workers}), root / f"{preset}-{n}-w{workers}"
            seconds[n] = timed(lambda e=engine, d=data: e.generate(d))
        out[workers] = rate(seconds)
        print(f"{preset} render, {workers} worker(s): {json.dumps(out[workers])}", flush=True)
    return out


def learn_rates(sizes: list[int], root: Path, backgrounds: Path | None) -> dict:
    """Composite and learning seconds per image on quick renders, with each preset's training settings."""
    from deformsim import Engine
    from deformsim.config import load_config

    composite, learn = {}, {p: {} for p in PRESETS}
    for n in sizes:
        data = root / f"learn-{n}"
        Engine("quick", {"generate.n": n}).generate(data)
        composite[n] = timed(lambda d=data: Engine("quick").composite(d, "backgrounds", backgrounds=backgrounds))
        for preset in PRESETS:
            train = load_config(preset).train.model_dump(mode="json")
            cache = root / f"cache-{preset}-{n}"
            shutil.copytree(root / "cache", cache)  # converted weights, no features: every image goes through the stem
            os.environ["DEFORMSIM_CACHE"] = str(cache)
            engine = Engine("quick", {f"train.{k}": v for k, v in train.items()})
            report = root / f"report-{preset}-{n}"
            learn[preset][n] = timed(lambda e=engine, d=data, r=report: e.report(d, r))
            print(f"{preset} learning on {n} images: {learn[preset][n]:.1f} s", flush=True)
    return {"composite": rate(composite), "learn": {p: rate(s) for p, s in learn.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backgrounds", type=Path, default=SHARED / "backgrounds" if (SHARED / "backgrounds").is_dir() else None)
    ap.add_argument("--out", type=Path, default=Path("runs/throughput"))
    ap.add_argument("--render-sizes", type=positive_int, nargs=2, default=[16, 48],
                    help="images in the two render runs (whole samples of 4 for both workers)")
    ap.add_argument("--paper-sizes", type=positive_int, nargs=2, default=[8, 24], help="the same for the paper preset (512 px)")
    ap.add_argument("--learn-sizes", type=positive_int, nargs=2, default=[32, 96], help="images in the two learning runs")
    args = ap.parse_args()
    from deformsim.config import load_config
    from deformsim.learn.weights import resolve

    with tempfile.TemporaryDirectory(prefix="deformsim-throughput-") as tmp:
        root = Path(tmp)
        os.environ["DEFORMSIM_CACHE"] = str(root / "cache")
        for preset in PRESETS:
            train = load_config(preset).train
            resolve(train.backbone, train.weights)  # convert the offline weights once, outside the timings
        render = {"quick": render_rates("quick", args.render_sizes, root),
                  "paper": render_rates("paper", args.paper_sizes, root)}
        learned = learn_rates(args.learn_sizes, root, args.backgrounds)
    results = {}
    for preset in PRESETS:
        per_image = learned["composite"]["seconds_per_image"] + learned["learn"][preset]["seconds_per_image"]
        results[preset] = {
            "render": {w: r for w, r in render[preset].items()},
            "composite_per_1000": 1000 * learned["composite"]["seconds_per_image"],
            "learn_per_1000": 1000 * learned["learn"][preset]["seconds_per_image"],
            "learn": learned["learn"][preset],
            "paper_scale_hours": {w: PAPER_N * (render[preset][w]["seconds_per_image"] + per_image) / 3600
                                  for w in (1, 2)},
        }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "throughput.json").write_text(json.dumps(results, indent=1))
    print(f"\n{'preset':<7} {'render img/h, 1 worker':>23} {'2 workers':>10} {'composite s/1000':>17} "
          f"{'learning s/1000':>16} {PAPER_N} images, h: {'1 worker':>9} {'2 workers':>10}")
    for preset, r in results.items():
        print(f"{preset:<7} {3600 / r['render'][1]['seconds_per_image']:>23.0f} "
              f"{3600 / r['render'][2]['seconds_per_image']:>10.0f} {r['composite_per_1000']:>17.1f} "
              f"{r['learn_per_1000']:>16.0f} {'':>17}{r['paper_scale_hours'][1]:>9.2f} {r['paper_scale_hours'][2]:>10.2f}")
    print(f"one-off seconds and every run: {args.out / 'throughput.json'}")


if __name__ == "__main__":
    run_main(main)
