"""The default model's learning stage, seconds per 1000 images: this checkout against another git revision.

    python bench/learn_against.py [DATA [--variant NAME]] [--against main] [--n 128] [--rounds 2] [--set KEY=VALUE]

The revision's ``src/`` is taken from git (``git archive``) into a temporary folder. Each round trains the quick
preset's model (``--set`` overrides it: both backbones, three seeds each, 15 epochs on cached stems) on the same
images once with each code, the revision first, each in a fresh process with an empty feature cache, so the time
holds the frozen layers' pass over every image, every member's epochs and the saved model, and the load of other
processes falls on both alike. DATA is a generated dataset (its ``--variant``, default backgrounds) of which ``--n``
images are used, half of each class; without it, ``--n`` blob images (tests/learn/blobs.py). The backbones' weights
are resolved (converted once into the shared cache) before the clock starts. Prints each run's seconds per 1000
images and the ratio of the revision's to this checkout's per round.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, positive_int, run_main


def _child(table_csv: Path, sets: list[str], out_json: Path) -> None:
    """Train once with the ``deformsim`` on the path (the revision's or this checkout's), and write the seconds."""
    import logging

    import pandas as pd

    from deformsim.cli.common import parse_sets
    from deformsim.config import load_config
    from deformsim.learn.train import fit
    from deformsim.learn.weights import resolve
    from deformsim.log import get_logger

    get_logger("deformsim").setLevel(logging.ERROR)
    cfg = load_config("quick", parse_sets(sets)).train
    for backbone in [cfg.backbone, *cfg.ensemble_backbones]:
        resolve(backbone, cfg.weights)
    table = pd.read_csv(table_csv)
    t0 = time.perf_counter()
    fit(table, cfg, out_json.parent / "model", progress=False)
    seconds = time.perf_counter() - t0
    info = json.loads((out_json.parent / "model" / "train.json").read_text())
    import deformsim

    out_json.write_text(json.dumps({"seconds": seconds, "images": len(table), "code": deformsim.__file__,
                                    "val_acc": (info.get("mixture_validation") or info.get("ensemble") or {}).get("val_acc")}))


def _table(args, tmp: Path):
    import pandas as pd

    if args.data:
        from deformsim.dataset.tables import load_table

        table = load_table(args.data, args.variant, "backgrounds")
        return table.groupby("y").head(args.n // 2)[["id", "path", "y"]]
    sys.path.insert(0, str(ROOT / "tests" / "learn"))
    from blobs import make_blobs

    return pd.DataFrame(make_blobs(tmp / "blobs", args.n // 2, size=128)[["id", "path", "y"]])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", type=Path)
    ap.add_argument("--variant", default=None)
    ap.add_argument("--against", default="main", help="git revision to compare with")
    ap.add_argument("--n", type=positive_int, default=128, help="images (half of each class)")
    ap.add_argument("--rounds", type=positive_int, default=2)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old_src = tmp / "old"
        old_src.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.against, "src"], capture_output=True)
        if archive.returncode:
            raise SystemExit(f"error: git archive {args.against}: {archive.stderr.decode().strip()}")
        subprocess.run(["tar", "-x", "-C", str(old_src)], input=archive.stdout, check=True)
        table = _table(args, tmp)
        table.to_csv(tmp / "table.csv", index=False)
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.against], capture_output=True,
                             text=True).stdout.strip()
        print(f"{len(table)} images ({args.data or 'blobs'}), quick preset {' '.join(args.sets)}; "
              f"{args.against} ({rev}) against this checkout, seconds per 1000 images", flush=True)
        codes = {args.against: old_src / "src", "this checkout": ROOT / "src"}
        seconds: dict[str, list[float]] = {k: [] for k in codes}
        for r in range(args.rounds):
            for name, src in codes.items():
                run = tmp / f"run-{r}-{len(seconds[name])}-{name.replace(' ', '_')}"
                run.mkdir()
                shutil.rmtree(_cache() / "features", ignore_errors=True)
                env = {**os.environ, "PYTHONPATH": f"{src}{os.pathsep}{ROOT / 'bench'}", "DEFORMSIM_CACHE": str(_cache())}
                subprocess.run([sys.executable, __file__, "--child", str(tmp / "table.csv"), str(run / "out.json"),
                                *args.sets], env=env, check=True, cwd=ROOT)
                out = json.loads((run / "out.json").read_text())
                if not Path(out["code"]).is_relative_to(src):
                    raise SystemExit(f"error: the {name} run imported {out['code']}, not {src}")
                seconds[name].append(1000 * out["seconds"] / out["images"])
                print(f"  round {r + 1}, {name}: {seconds[name][-1]:.1f} s per 1000 images "
                      f"(held-out accuracy {out['val_acc']:.3f})", flush=True)
            print(f"round {r + 1}: {args.against} / this checkout = "
                  f"{seconds[args.against][-1] / seconds['this checkout'][-1]:.2f}x", flush=True)
        shutil.rmtree(_cache() / "features", ignore_errors=True)
        old, new = min(seconds[args.against]), min(seconds["this checkout"])
        print(f"fastest of {args.rounds}: {args.against} {old:.1f} s, this checkout {new:.1f} s per 1000 images, "
              f"{old / new:.2f}x")


def _cache() -> Path:
    """The benchmark's own cache (converted weights kept between runs, feature caches emptied before each)."""
    base = os.environ.get("DEFORMSIM_BENCH_CACHE") or str(Path(tempfile.gettempdir()) / "deformsim-bench-cache")
    return Path(base)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        sys.path.remove(str(ROOT / "src"))  # put there by _util: the child runs the code on PYTHONPATH
        _child(Path(sys.argv[2]), sys.argv[4:], Path(sys.argv[3]))
    else:
        run_main(main)
