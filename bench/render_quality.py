"""Render quality per second: Cycles settings vs seconds per image and SSIM/PSNR against a converged reference.

    .venv/bin/python bench/render_quality.py [--quick] [--out runs/render_quality] [--resolutions 128 256 512]

Scenes: the paper preset's can, 2 intact + 2 deformed states drawn with --seed, each seen by one of the
four cameras under its own HDRI. Per resolution one worker renders each scene's reference (--ref-samples,
more bounces, no clamping, denoised so that the residual noise of a finite sample count does not count
against the denoised candidates; cached in OUT/ref/) and then every candidate of the grid on every scene in
one shuffled order, today's settings (twice, to show the timing noise) among them, so that load from other
processes falls on all settings alike. Quality is measured on the object's bounding box (plus a margin) of
the RGBA render composited over mid grey, in 8-bit sRGB: SSIM (mean over R, G, B) and PSNR. Seconds are
Cycles' render call per image (scene sync, path tracing, denoising) and the worker's wall time per image.
Writes OUT/results.json; prints a table and the Pareto front (seconds vs SSIM) per resolution.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
from _util import ROOT, positive_int, run_main
from PIL import Image

from deformsim.atomic import write_bytes, write_json
from deformsim.config import RenderConfig, load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.evaluate.image_quality import psnr, ssim
from deformsim.generate.identity import RENDERER
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec

TODAY = {"samples": 32, "denoise": True}  # the "today" rows: the paper preset's earlier settings (fixed samples, 6 bounces)
TODAY_128 = {"samples": 16, "denoise": True}  # the quick preset's settings, the "today" rows at 128 px
REFERENCE = {"denoise": True, "max_bounces": 16, "diffuse_bounces": 8, "glossy_bounces": 8, "transmission_bounces": 12,
             "transparent_bounces": 8, "clamp_direct": 0.0, "clamp_indirect": 0.0}
FAST_DN = {"denoise_prefilter": "fast", "denoise_quality": "balanced"}
LOW_BOUNCES = {"max_bounces": 3, "diffuse_bounces": 2, "glossy_bounces": 2, "transmission_bounces": 2,
               "transparent_bounces": 2}
CLAMP = {"caustics_reflective": False, "caustics_refractive": False, "clamp_indirect": 1.0}
GRID = {
    "today": {},
    "today (again)": {},
    "16 spp": {"samples": 16},
    "8 spp": {"samples": 8},
    "adaptive 0.05": {"adaptive": True, "adaptive_threshold": 0.05, "adaptive_min_samples": 8},
    "bounces 3/2": LOW_BOUNCES,
    "bounces 12/8": {"max_bounces": 12, "diffuse_bounces": 8, "glossy_bounces": 8},
    "no caustics, clamp 1": CLAMP,
    "prefilter fast": {"denoise_prefilter": "fast"},
    "prefilter none": {"denoise_prefilter": "none"},
    "guides albedo": {"denoise_input": "rgb_albedo"},
    "denoise balanced": {"denoise_quality": "balanced"},
    "denoise fast": {"denoise_quality": "fast"},
    "tile 256": {"tile_size": 256},
    "16 spp + prefilter fast": {"samples": 16, "denoise_prefilter": "fast"},
    "16 spp + prefilter none": {"samples": 16, "denoise_prefilter": "none"},
    "16 spp + fast dn": {"samples": 16, **FAST_DN},
    "8 spp + fast dn": {"samples": 8, **FAST_DN},
    "8 spp + fast dn + b3 + clamp": {"samples": 8, **FAST_DN, **LOW_BOUNCES, **CLAMP},
    "4 spp + fast dn + b3 + clamp": {"samples": 4, **FAST_DN, **LOW_BOUNCES, **CLAMP},
    "world map 2048": {"world_map": 2048},
    "world map 1024": {"world_map": 1024},
    "world map 512": {"world_map": 512},
    "world map 256": {"world_map": 256},
    "world map 128": {"world_map": 128},
    "8 spp + world map 2048": {"samples": 8, "world_map": 2048},
}
FULL_GRID = ("today", "today (again)", "16 spp", "adaptive 0.05", "bounces 3/2", "no caustics, clamp 1", "prefilter fast",
             "prefilter none", "guides albedo", "denoise balanced", "tile 256", "16 spp + prefilter fast",
             "16 spp + prefilter none", "16 spp + fast dn", "8 spp + fast dn", "8 spp + fast dn + b3 + clamp")
QUICK_GRID = ("today", "today (again)", "8 spp", "prefilter fast", "8 spp + fast dn")
GREY = 128


def scenes(n: int, seed: int, cfg, spec, hdris: list[str]) -> list:
    """``n`` scene states, half intact and half deformed, each with its own HDRI where possible, one camera each."""
    want = {"intact": (n + 1) // 2, "deformed": n // 2}
    out, used = [], set()
    for index in range(1000):
        p = sample_params(index, seed, cfg, spec, hdris)
        if want[p.label] and (p.hdri not in used or len(used) >= len(hdris)):
            want[p.label] -= 1
            used.add(p.hdri)
            out.append(p)
        if len(out) == n:
            break
    return [dataclasses.replace(p, index=k, cameras=(p.cameras[k % len(p.cameras)],)) for k, p in enumerate(out)]


def over_grey(rgba: np.ndarray, box: tuple[slice, slice]) -> np.ndarray:
    """The RGBA render over mid grey inside ``box``, as float RGB in [0, 1]."""
    rgba = rgba[box].astype(np.float64) / 255
    return rgba[..., :3] * rgba[..., 3:] + GREY / 255 * (1 - rgba[..., 3:])


def object_box(alpha: np.ndarray) -> tuple[slice, slice]:
    """Bounding box of the covered pixels plus a margin of 1/32 of the image (at least the SSIM window)."""
    ys, xs = np.nonzero(alpha)
    if ys.size == 0:
        raise RuntimeError("the reference shows no object")
    m = max(alpha.shape[0] // 32, 11)
    return (slice(max(ys.min() - m, 0), ys.max() + m + 1), slice(max(xs.min() - m, 0), xs.max() + m + 1))


class Bench:
    """One worker at one resolution; renders samples with any render settings and returns pixels and seconds."""

    def __init__(self, cfg, res: int, out: Path):
        self.layout = Layout(out / "work" / str(res))
        self.worker = WorkerProcess(out / "logs" / f"worker{res}.log")
        self.ready = self.worker.start({"config": cfg.model_dump(mode="json"), "spec_path": None,
                                        "out": str(self.layout.root)})

    def render(self, render: dict, p) -> tuple[np.ndarray, float, float]:
        self.worker.configure(render)
        t0 = time.perf_counter()
        reply = self.worker.render(p.to_dict())
        wall = time.perf_counter() - t0
        if "error" in reply:
            raise RuntimeError(f"scene {p.index} failed: {reply['message']}")
        with Image.open(self.layout.image("rgba", image_id(p.index, 0))) as im:
            return np.array(im.convert("RGBA")), reply["render_seconds"][0], wall


def reference(bench: Bench, render: dict, p, out: Path) -> np.ndarray:
    """The scene's reference render, from OUT/ref/ when it was made with the same scene and settings."""
    key = json.dumps({"scene": p.to_dict(), "render": render, "renderer": RENDERER}, sort_keys=True)
    png, meta = out / "ref" / str(render["resolution"]) / f"{p.index}.png", out / "ref" / f"{render['resolution']}-{p.index}.json"
    if png.exists() and meta.exists() and meta.read_text() == key:
        return np.array(Image.open(png))
    t0 = time.perf_counter()
    rgba, _, _ = bench.render(render, p)
    print(f"  reference {render['resolution']} px scene {p.index}: {time.perf_counter() - t0:.0f} s", flush=True)
    write_bytes(png, bench.layout.image("rgba", image_id(p.index, 0)).read_bytes())
    write_bytes(meta, key.encode())  # written last: a reference counts only once its key is there
    return rgba


def run_resolution(res: int, grid: dict, states: list, args, cfg) -> list[dict]:
    today = TODAY_128 if res <= 128 else TODAY
    base = {**RenderConfig().model_dump(), "resolution": res}  # the defaults: today's settings but samples
    settings = {name: RenderConfig.model_validate({**base, **today, **o}) for name, o in grid.items()}
    preset = "quick" if res <= 128 else "paper"  # the preset's chosen settings, if not the "today" ones
    render = load_config(preset, {"render.resolution": res, "render.dense": False, "render.threads": 0}).render
    if render != settings["today"]:
        settings[f"{preset} preset"] = render
        grid = {**grid, f"{preset} preset": {}}
    ref_render = RenderConfig.model_validate({**base, "samples": args.ref_samples, **REFERENCE}).model_dump(mode="json")
    bench = Bench(cfg, res, args.out)
    rng = np.random.default_rng(args.seed)
    try:
        refs = [reference(bench, ref_render, p, args.out) for p in states]
        boxes = [object_box(r[..., 3]) for r in refs]
        order = [(name, k) for name in grid for k in range(len(states)) for _ in range(args.repeats)]
        rows = {name: {"name": name, "resolution": res, "render": settings[name].model_dump(mode="json"), "scenes": []}
                for name in grid}
        for i in rng.permutation(len(order)):
            name, k = order[i]
            rgba, secs, wall = bench.render(settings[name].model_dump(mode="json"), states[k])
            a, b = over_grey(rgba, boxes[k]), over_grey(refs[k], boxes[k])
            a, b = np.round(a * 255) / 255, np.round(b * 255) / 255
            rows[name]["scenes"].append({"scene": k, "label": states[k].label, "hdri": states[k].hdri, "seconds": secs,
                                         "wall": wall, "ssim": ssim(a, b), "psnr": psnr(a, b)})
    finally:
        bench.worker.close()
    for r in rows.values():
        s = r["scenes"]
        r.update(seconds=float(np.mean([x["seconds"] for x in s])), wall=float(np.mean([x["wall"] for x in s])),
                 ssim=float(np.mean([x["ssim"] for x in s])), ssim_min=float(min(x["ssim"] for x in s)),
                 psnr=float(np.mean([x["psnr"] for x in s])))
    today_s = rows["today"]["seconds"]
    for r in rows.values():
        r["speedup"] = today_s / r["seconds"]
    front = pareto(list(rows.values()))
    for r in rows.values():
        r["pareto"] = r["name"] in front
    return list(rows.values())


def pareto(rows: list[dict]) -> list[str]:
    """Names of the rows no other row beats on both seconds (lower) and SSIM (higher), fastest first."""
    front, best = [], -1.0
    for r in sorted(rows, key=lambda r: (r["seconds"], -r["ssim"])):
        if r["ssim"] > best:
            front.append(r["name"])
            best = r["ssim"]
    return front


def print_table(rows: list[dict]) -> None:
    print(f"\n{rows[0]['resolution']} px   (x = images per hour relative to today; * = Pareto front, seconds vs SSIM)")
    print(f"{'setting':<30} {'s/image':>8} {'wall s':>7} {'x':>5} {'SSIM':>7} {'min':>7} {'PSNR':>6}")
    for r in sorted(rows, key=lambda r: r["seconds"]):
        print(f"{r['name']:<30} {r['seconds']:>8.2f} {r['wall']:>7.2f} {r['speedup']:>5.2f} {r['ssim']:>7.4f} "
              f"{r['ssim_min']:>7.4f} {r['psnr']:>6.1f} {'*' if r['pareto'] else ''}")
    front = sorted((r for r in rows if r["pareto"]), key=lambda r: r["seconds"])
    print("Pareto front: " + " -> ".join(f"{r['name']} ({r['seconds']:.2f} s, {r['ssim']:.4f})" for r in front))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "runs" / "render_quality", help="results, references, logs")
    ap.add_argument("--quick", action="store_true", help="2 scenes, 128 px, 5 settings: a smoke run of a few minutes")
    ap.add_argument("--resolutions", type=positive_int, nargs="+", help="default: 512 128 256 (--quick: 128)")
    ap.add_argument("--scenes", type=positive_int, help="scene states (half intact); default 4 (--quick: 2)")
    ap.add_argument("--ref-samples", type=positive_int, help="reference samples per pixel; default 512 (--quick: 128)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="these settings of the grid only (today is always kept)")
    ap.add_argument("--repeats", type=positive_int, default=1, help="renders of each setting and scene (timing noise)")
    ap.add_argument("--seed", type=int, default=0, help="draws the scenes and the render order")
    args = ap.parse_args()
    args.resolutions = args.resolutions or ([128] if args.quick else [512, 128, 256])
    args.scenes = args.scenes or (2 if args.quick else 4)
    args.ref_samples = args.ref_samples or (128 if args.quick else 512)
    names = set(args.only or (QUICK_GRID if args.quick else FULL_GRID)) | {"today"}
    unknown = sorted(names - set(GRID))
    if unknown or min(args.resolutions) < 16 or min(args.scenes, args.repeats) < 1 or not 1 <= args.ref_samples <= 4096:
        bad = (f"unknown setting {unknown[0]!r} (known: {', '.join(GRID)})" if unknown else f"bad --resolutions "
               f"{args.resolutions}, --scenes {args.scenes}, --repeats {args.repeats} or --ref-samples {args.ref_samples}")
        raise SystemExit(f"error: {bad}")
    grid = {n: o for n, o in GRID.items() if n in names}
    cfg = load_config("paper", {"generate.n": 4, "generate.seed": args.seed, "render.dense": False,
                                "render.render_backgrounds": False, "render.threads": 0})
    spec, hdris = load_spec(None), list_hdris(None)
    states = scenes(args.scenes, args.seed, cfg, spec, hdris)
    cfg = load_config("paper", {"generate.n": 4, "generate.seed": args.seed, "render.dense": False, "render.threads": 0,
                                "camera.azimuth_quadrants": [list(cfg.camera.azimuth_quadrants[0])]})
    print(f"scenes: {', '.join(f'{p.label}/{p.hdri}' for p in states)}; reference {args.ref_samples} spp, denoised")
    t0 = time.perf_counter()
    results = []
    for res in args.resolutions:
        rows = run_resolution(res, grid, states, args, cfg)
        print_table(rows)
        results += rows  # written after each resolution: a long run keeps what it measured
        write_json(args.out / "results.json", {"args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
                                               "reference": REFERENCE, "scenes": [p.to_dict() for p in states], "rows": results})
    print(f"\n{time.perf_counter() - t0:.0f} s in all; results: {args.out / 'results.json'}")


if __name__ == "__main__":
    run_main(main)
