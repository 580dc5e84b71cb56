"""Learning-stage seconds per 1000 images, per backbone and mode, on this machine.

    python bench/learning.py [--n 32] [--size 128] [--backbones vgg16,efficientnet_lite0,...]

For each backbone (random weights: timings do not depend on them, and the zoo's downloads need the internet):
- ``stem``: the frozen layers once per image (what fills the feature cache), images decoded included, in
  torch's default layout and in channels-last (the ratio says whether it pays: ``DeformNet.stem`` runs
  channels-last where ``Backbone.channels_last`` says so);
- ``frozen``: one training epoch on cached stem activations (the default mode: last conv + head);
- ``finetune``: one training epoch through the whole network with augmentation, the last block trained.
Each is the fastest of ``--repeats`` runs on n + n blob images (tests/learn/blobs.py), scaled to 1000 images.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, positive_int, run_main

sys.path.insert(0, str(ROOT / "tests" / "learn"))

from deformsim.learn.backbones import BACKBONES  # noqa: E402
from deformsim.log import get_logger  # noqa: E402


def _stem_seconds(model, paths: list[str], size: int, channels_last: bool, repeats: int) -> float:
    import torch

    from deformsim.learn.data import ImageSet

    stem = model.features[: model.cut].eval()
    if channels_last:
        stem = stem.to(memory_format=torch.channels_last)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        with torch.inference_mode():
            for x in torch.utils.data.DataLoader(ImageSet(paths, size), batch_size=32):
                x = (x - model.mean) / model.std
                stem(x.contiguous(memory_format=torch.channels_last) if channels_last else x)
        best = min(best, time.perf_counter() - t0)
    if channels_last:
        stem.to(memory_format=torch.contiguous_format)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=positive_int, default=32, help="blob images per class")
    ap.add_argument("--size", type=positive_int, default=128)
    ap.add_argument("--repeats", type=positive_int, default=2)
    ap.add_argument("--backbones", default=",".join(BACKBONES))
    args = ap.parse_args()
    get_logger("deformsim").setLevel(logging.ERROR)  # one epoch on random weights learns nothing: timed only
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["DEFORMSIM_CACHE"] = str(Path(tmp) / "cache")
        import torch
        from blobs import make_blobs

        from deformsim.config import TrainConfig
        from deformsim.learn.device import set_threads
        from deformsim.learn.models import build
        from deformsim.learn.train import fit

        set_threads()
        table = make_blobs(Path(tmp) / "blobs", args.n, size=args.size)
        paths = list(table["path"])
        per = 1000 / len(paths)
        print(f"{len(paths)} images at {args.size} px, batch 32, {torch.get_num_threads()} threads, "
              f"seconds per 1000 images (fastest of {args.repeats})")
        print("| backbone | stem | stem, channels-last | ratio | frozen epoch | fine-tune epoch (last block) |")
        print("|---|---|---|---|---|---|")
        for name in args.backbones.split(","):
            cfg = TrainConfig(backbone=name, weights="none", image_size=args.size, epochs=1)
            model, _ = build(cfg)
            _stem_seconds(model, paths[:4], args.size, False, 1)  # warm up
            plain = _stem_seconds(model, paths, args.size, False, args.repeats)
            last = _stem_seconds(model, paths, args.size, True, args.repeats)
            frozen = min(fit(table, cfg, Path(tmp) / f"{name}-frozen", progress=False).history[0]["seconds"]
                         for _ in range(args.repeats))
            tune = cfg.model_copy(update={"augment": True, "cache_features": False, "finetune": "last_block"})
            finetune = fit(table, tune, Path(tmp) / f"{name}-finetune", progress=False).history[0]["seconds"]
            # frozen and fine-tune epochs train on the 80 % split: per 1000 images of that split
            split = per / 0.8
            print(f"| {name} | {plain * per:.1f} | {last * per:.1f} | {plain / last:.2f}x | {frozen * split:.2f} | "
                  f"{finetune * split:.1f} |", flush=True)


if __name__ == "__main__":
    run_main(main)
