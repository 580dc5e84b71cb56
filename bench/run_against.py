"""Wall time of one `deformsim run`, this checkout against another git revision, in one run on this machine.

    python bench/run_against.py [--against b5cd3d5] [--first new] -- RUN-ARGUMENTS...

e.g. the tin example at a tenth of its renders (paths outside the repository absolute):

    python bench/run_against.py --against b5cd3d5 -- --config examples/tin/config.yaml --object $PWD/runs/tins/tin.stl \
        --spec examples/tin/spec.yaml --real $PWD/../shared/data/real_tins_dev --n 64

The revision's ``src/``, ``examples/`` and ``configs/`` are taken from git (``git archive``) into a temporary folder,
and each code runs ``deformsim run RUN-ARGUMENTS --out TMP --no-progress`` in a fresh process from its own tree, so a
relative ``--config examples/...`` is each version's own example (its render settings included), with an empty run
folder and an empty feature cache. The two runs go one after the other (``--first`` says which; on 2 cores running
them side by side would time the contention). Prints each run's time per stage, its total wall time and the ratio.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, run_main

_STAGE = re.compile(r"^\s{2}(\S.*?)\s+([\d.]+) s$")


def _checkout(rev: str, into: Path) -> None:
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src", "examples", "configs"],
                             capture_output=True)
    if archive.returncode:
        raise SystemExit(f"error: git archive {rev}: {archive.stderr.decode().strip()}")
    into.mkdir()
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)


def _run(tree: Path, args: list[str], out: Path, cache: Path) -> tuple[float, dict[str, float], str]:
    """Run ``deformsim run`` with the code of ``tree``; its wall seconds, seconds per stage and the output's tail."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "DEFORMSIM_CACHE": str(cache)}
    code = (f"import deformsim, sys; assert deformsim.__file__.startswith({str(tree / 'src')!r}), deformsim.__file__; "
            "from deformsim.cli import app; sys.argv = ['deformsim'] + sys.argv[1:]; app()")
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, "run", *args, "--out", str(out), "--no-progress", "--yes"],
                          cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"error: deformsim run in {tree} failed:\n{done.stderr[-3000:]}")
    stages = {m.group(1): float(m.group(2)) for line in done.stdout.splitlines() if (m := _STAGE.match(line))}
    return wall, stages, done.stdout[-1500:]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", default="b5cd3d5", help="git revision to compare with (default: 0.2.0)")
    ap.add_argument("--first", choices=("old", "new"), default="old", help="which code runs first")
    ap.add_argument("run_args", nargs=argparse.REMAINDER, help="-- then the arguments of deformsim run")
    args = ap.parse_args()
    run_args = args.run_args[1:] if args.run_args[:1] == ["--"] else args.run_args
    if not run_args:
        raise SystemExit("error: give deformsim run's arguments after --")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        _checkout(args.against, tmp / "old")
        trees = {args.against: tmp / "old", "this checkout": ROOT}
        order = list(trees) if args.first == "old" else list(trees)[::-1]
        print(f"deformsim run {' '.join(run_args)}\n{args.against} against this checkout, one after the other",
              flush=True)
        walls = {}
        for name in order:
            walls[name], stages, tail = _run(trees[name], run_args, tmp / f"run-{len(walls)}", tmp / f"cache-{len(walls)}")
            print(f"{name}: {walls[name]:.1f} s wall", flush=True)
            for stage, secs in stages.items():
                print(f"  {stage:<36} {secs:7.1f} s", flush=True)
        print(f"{args.against} / this checkout = {walls[args.against] / walls['this checkout']:.2f}x")


if __name__ == "__main__":
    run_main(main)
