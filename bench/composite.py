"""Compositing speed and matte quality: the paper's per-image OpenCV loop against `deformsim composite`.

    python bench/composite.py [DATASET] [--backgrounds DIR] [--repeat N]

Without DATASET a small one is rendered first (32 images, 128 px). Both methods composite the same images
onto photos from the same folder (default: the shared BG-20k stand-in) and print images per second, their
ratio, and the mean IoU of each matte against the exact render alpha (binarised at 0.5, and soft).
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from _util import SHARED, positive_int, run_main

from deformsim.composite.backgrounds import load_photo, scan_backgrounds
from deformsim.composite.matte import binary_iou, chroma_matte
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig, load_config
from deformsim.dataset.manifest import read_manifest


def soft_iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.minimum(a, b).sum() / max(np.maximum(a, b).sum(), 1e-9))


def paper_loop(root: Path, ids: list[str], photos: list[Path], cfg: CompositeConfig, out: Path) -> list[np.ndarray]:
    """Read, inRange, closing, opening, erosion, bitwise compose over a resized photo, write: per image."""
    key = np.array(cfg.key_color[::-1])  # BGR
    lo, hi = np.clip(key - cfg.tolerance, 0, 255), np.clip(key + cfg.tolerance, 0, 255)
    sizes = (cfg.close_kernel, cfg.open_kernel, cfg.erode_kernel)
    kern = {k: cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)) for k in sizes}
    rng = np.random.default_rng(0)
    masks = []
    for iid in ids:
        img = cv2.imread(str(root / "images" / "green" / f"{iid}.png"))
        mask = 255 - cv2.inRange(img, lo, hi)
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kern[cfg.close_kernel])
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kern[cfg.open_kernel])
        mask = cv2.erode(mask, kern[cfg.erode_kernel])
        bg = cv2.imread(str(photos[rng.integers(len(photos))]))
        bg = cv2.resize(bg, (img.shape[1], img.shape[0]), interpolation=cv2.INTER_AREA)
        comp = cv2.add(cv2.bitwise_and(img, img, mask=mask), cv2.bitwise_and(bg, bg, mask=255 - mask))
        cv2.imwrite(str(out / f"{iid}.png"), comp)
        masks.append(mask)
    return masks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", nargs="?", type=Path)
    ap.add_argument("--backgrounds", type=Path, default=SHARED / "backgrounds")
    ap.add_argument("--repeat", type=positive_int, default=3, help="timed passes over the images (best is kept)")
    args = ap.parse_args()
    photos = scan_backgrounds(args.backgrounds)
    tmp = tempfile.TemporaryDirectory()
    root = args.dataset
    if root is None:
        from deformsim.generate.stage import generate

        root = Path(tmp.name) / "data"
        print("rendering 32 images at 128 px ...", flush=True)
        generate(load_config("quick", {"generate.n": 32, "render.resolution": 128, "render.samples": 8,
                                       "generate.preview": 0}), root, progress=False)
    df = read_manifest(root)
    ids = list(df["id"])
    cfg = CompositeConfig(backgrounds=args.backgrounds)
    exact = [cv2.imread(str(root / "images" / "rgba" / f"{i}.png"), cv2.IMREAD_UNCHANGED)[..., 3] / 255.0 for i in ids]

    def best(fn) -> tuple[float, object]:
        times, result = [], None
        for _ in range(args.repeat):
            load_photo.cache_clear()  # no decoded photo carries over from an earlier pass
            t0 = time.perf_counter()
            result = fn()
            times.append(time.perf_counter() - t0)
        return len(ids) / min(times), result

    out = Path(tmp.name) / "paper"
    out.mkdir()
    paper_rate, masks = best(lambda: paper_loop(root, ids, photos, cfg, out))
    ours = {}
    for workers in (1, 0):
        c = cfg.model_copy(update={"workers": workers})
        ours[workers] = best(lambda c=c: composite(root, c, "bench", seed=0, progress=False))
    shutil.rmtree(ours[0][1])  # leave the dataset as it was
    greens = [cv2.cvtColor(cv2.imread(str(root / "images" / "green" / f"{i}.png")), cv2.COLOR_BGR2RGB) for i in ids]
    mattes = [chroma_matte(g, cfg)[0] for g in greens]
    p_bin = np.mean([binary_iou(m / 255.0, e) for m, e in zip(masks, exact)])
    p_soft = np.mean([soft_iou(m / 255.0, e) for m, e in zip(masks, exact)])
    o_bin = np.mean([binary_iou(m, e) for m, e in zip(mattes, exact)])
    o_soft = np.mean([soft_iou(m, e) for m, e in zip(mattes, exact)])
    h, w = exact[0].shape
    auto = max(1, min(os.cpu_count() or 1, 8, -(-len(ids) // 16)))
    print(f"{len(ids)} images {w}x{h}, {len(photos)} background photos, best of {args.repeat}")
    print(f"paper loop (inRange, hard mask)  {paper_rate:8.1f} img/s   IoU {p_bin:.4f} (soft {p_soft:.4f})")
    print(f"deformsim composite, 1 worker    {ours[1][0]:8.1f} img/s   IoU {o_bin:.4f} (soft {o_soft:.4f})"
          f"   ratio {ours[1][0] / paper_rate:.2f}x")
    print(f"deformsim composite, auto ({auto})   {ours[0][0]:8.1f} img/s"
          f"   ratio {ours[0][0] / paper_rate:.2f}x")


if __name__ == "__main__":
    run_main(main)
