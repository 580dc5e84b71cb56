"""Epoch time with and without the frozen-layer feature cache, on the same data and seed.

    python bench/train.py [DATA [--variant NAME]] [--size 128] [--epochs 3] [--n 48]

DATA is a generated dataset or a folder of intact/ + deformed/ photos; without it, an easy synthetic set
of n + n blob images (tests/learn/blobs.py) is made. Prints the mean
epoch time of each mode, their ratio, the one-off cost of filling the cache, and both validation accuracies.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, positive_int, run_main

sys.path.insert(0, str(ROOT / "tests" / "learn"))

from deformsim.config import TrainConfig  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", type=Path)
    ap.add_argument("--variant", default=None)
    ap.add_argument("--size", type=positive_int, default=128)
    ap.add_argument("--epochs", type=positive_int, default=3)
    ap.add_argument("--n", type=positive_int, default=48, help="blob images per class when no DATA is given")
    ap.add_argument("--backbone", default="vgg16")
    ap.add_argument("--weights", default="offline", help="timings do not depend on it; 'none' needs no package")
    ap.add_argument("--device", default="auto")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["DEFORMSIM_CACHE"] = str(Path(tmp) / "cache")  # start with an empty feature cache
        from deformsim.dataset.tables import load_table
        from deformsim.learn.train import fit

        if args.data:
            table = load_table(args.data, args.variant, "black")
        else:
            from blobs import make_blobs

            table = make_blobs(Path(tmp) / "blobs", args.n, size=args.size)
        cfg = TrainConfig(backbone=args.backbone, weights=args.weights, image_size=args.size, epochs=args.epochs,
                          device=args.device)
        import torch

        gpu = cfg.device != "cpu" and torch.cuda.is_available()
        where = torch.cuda.get_device_name() if gpu else f"{os.cpu_count()} CPU cores"
        print(f"{len(table)} images at {args.size} px, {cfg.backbone} ({cfg.weights} weights), batch {cfg.batch_size}, "
              f"{args.epochs} epochs, {where}")
        fit(table.groupby("y").head(2), cfg.model_copy(update={"epochs": 1, "cache_features": False}), Path(tmp) / "warm",
            progress=False)  # one-off costs first: imports, weights conversion, CUDA start
        results = {}
        for cached in (False, True):
            t0 = time.perf_counter()
            r = fit(table, cfg.model_copy(update={"cache_features": cached}), Path(tmp) / f"m{int(cached)}", progress=False)
            epochs = sum(h["seconds"] for h in r.history)
            results[cached] = (epochs / len(r.history), r.history[-1]["val_acc"], r.seconds - epochs)
            print(f"  cache {'on ' if cached else 'off'}: {results[cached][0]:7.2f} s/epoch, "
                  f"val acc {results[cached][1]:.3f}, setup {results[cached][2]:.1f} s (total {time.perf_counter() - t0:.1f} s)")
        off, on = results[False], results[True]
        print(f"epoch time ratio (no cache / cache): {off[0] / on[0]:.1f}x; "
              f"validation accuracy {off[1]:.3f} vs {on[1]:.3f}; the cache costs {on[2] - off[2]:.1f} s once")


if __name__ == "__main__":
    run_main(main)
