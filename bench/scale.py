"""Throughput of local workers: images per second with 1 and 2 worker processes, their ratio, and whether both
made the same images.

    python bench/scale.py [--config quick] [--n 32] [--rounds 1] [--set KEY=VALUE ...]

Each round renders the same ``--n`` images of the config (default: the quick preset at 96 px and 8 spp) with one
worker of all the cores' Cycles threads and with two workers of one thread each, each from an empty folder, and
prints each rate and their ratio; then whether the two made byte-identical RGBA images.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from _util import positive_int, run_main

SMALL = {"render.resolution": 96, "render.samples": 8}  # without --config: a small render, fixed costs count


def rate(cfg, out: Path) -> float:
    from deformsim.generate.stage import generate

    t0 = time.perf_counter()
    generate(cfg, out, progress=False)
    return cfg.generate.n / (time.perf_counter() - t0)


def digests(out: Path) -> dict[str, str]:
    from deformsim.identity import file_digest

    return {p.name: file_digest(p) for p in sorted((out / "images" / "rgba").glob("*.png"))}


def main() -> None:
    from deformsim.cli.common import parse_sets
    from deformsim.config import load_config

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=None, help="preset or YAML file (default: quick at 96 px, 8 spp)")
    ap.add_argument("--n", type=positive_int, default=32, help="images per run")
    ap.add_argument("--rounds", type=positive_int, default=1)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    given = {} if args.config else dict(SMALL)
    given |= parse_sets(args.sets) | {"generate.n": args.n, "generate.preview": 0}
    cfgs = {w: load_config(args.config or "quick", given | {"generate.workers": w}) for w in (1, 2)}
    res = cfgs[1].render
    print(f"{args.n} images at {res.resolution} px, {res.samples} spp ({args.config or 'quick, small'})")
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(1, args.rounds + 1):
            one, two = (rate(cfgs[w], Path(tmp) / f"w{w}-{r}") for w in (1, 2))
            print(f"round {r}: 1 worker {one:.3f} img/s, 2 workers {two:.3f} img/s, ratio 2/1 = {two / one:.2f}")
        same = digests(Path(tmp) / "w1-1") == digests(Path(tmp) / "w2-1")
        print(f"1 and 2 workers made {'byte-identical' if same else 'different'} RGBA images")


if __name__ == "__main__":
    run_main(main)
