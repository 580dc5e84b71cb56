"""Where a render worker's time goes, phase by phase, on the tin example (or any config): one worker in this process.

    python bench/render_phases.py [--config examples/tin/config.yaml] [--states 2] [--threads 2] [--set KEY=VALUE]
    python bench/render_phases.py --config quick --can    # the built-in can of a preset

Builds the tin mesh (examples/tin/make_tin.py) unless ``--object`` names one, sets the scene up as a ``generate``
worker does, renders sample 0 to warm up and then ``--states`` samples, and splits their wall time into: the scene
state (deformation, pose, materials, world, features), each Cycles call of the main image split by Cycles' own status
lines (scene sync, BVH, path tracing, denoising, the rest: Blender's PNG write and read-back), the white/black
backgrounds, each dense feature's work on the image and each extra pass (shadow, table, region) with its Cycles
phases, and deformsim's image writes; then Cycles' ten slowest status steps over every render call (such as the
world's light importance map). Seconds per sample and share of the wall time; Cycles' phases are timed between its
status callbacks (``bpy.app.handlers.render_stats``), so they are as fine as those come.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from _util import ROOT, positive_int, run_main

CYCLES_PHASES = (("bvh", "BVH"), ("denois", "denoising"), ("finished", "after the samples"), ("sample", "path tracing"),
                 ("path trac", "path tracing"))
MAIN = "main image (Cycles call, its PNG write and read-back)"


def _phase(stats: str) -> str:
    """Cycles' status line as a phase; every line before the samples (objects, shaders, kernels, lights, camera)
    is scene sync."""
    low = stats.lower()
    return next((name for key, name in CYCLES_PHASES if key in low), "scene sync")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "examples" / "tin" / "config.yaml"))
    ap.add_argument("--object", type=Path, default=None, help="mesh (default: make_tin.py's tin)")
    ap.add_argument("--can", action="store_true", help="the config's own object and spec (the built-in can of the "
                    "presets) instead of a mesh")
    ap.add_argument("--spec", default=str(ROOT / "examples" / "tin" / "spec.yaml"))
    ap.add_argument("--states", type=positive_int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    import bpy

    from deformsim.blender import worker
    from deformsim.blender.passes import render as rp
    from deformsim.cli.common import parse_sets
    from deformsim.config import load_config
    from deformsim.dataset.layout import Layout
    from deformsim.generate.backend import worker_setup
    from deformsim.hdri import list_hdris
    from deformsim.sampling import sample_params
    from deformsim.spec.model import load_spec

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        mesh = args.object
        if mesh is None and not args.can:
            mesh = tmp / "tin.stl"
            subprocess.run([sys.executable, str(ROOT / "examples" / "tin" / "make_tin.py"), str(mesh)], check=True,
                           capture_output=True)
        part = {} if args.can else {"object.mesh": str(mesh), "object.spec": args.spec}
        cfg = load_config(args.config, {**part, **parse_sets(args.sets)})
        msg = worker_setup(cfg, Layout(tmp / "out")) | {"threads": args.threads}
        t0 = time.perf_counter()
        ctx, layout, reply = worker.setup(msg)
        setup = time.perf_counter() - t0
        spec, hdris = load_spec(cfg.object.spec), list_hdris(cfg.lighting.hdri_dir)

        spent: dict[str, float] = defaultdict(float)  # exclusive seconds: a phase's time less its inner phases'
        cycles: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))  # phase -> Cycles phase -> s
        stack: list[list] = []  # [name, start, seconds of inner phases]
        cyc = {"phase": None, "since": 0.0, "line": ""}
        lines: dict[str, float] = defaultdict(float)  # Cycles' status step -> seconds, every render call

        def flush(now: float) -> None:
            if cyc["phase"] is not None and stack:
                cycles[stack[-1][0]][cyc["phase"]] += now - cyc["since"]
                lines[cyc["line"]] += now - cyc["since"]
            cyc["phase"] = None

        def stats(text, *_):
            now = time.perf_counter()
            flush(now)
            if stack:
                cyc["phase"], cyc["since"] = _phase(str(text)), now
                step = [w for w in str(text).split(" | ")[1:3] if not w.startswith(("Mem:", "Sample"))]
                cyc["line"] = " | ".join(step) or cyc["phase"]  # the step without memory, sample count or object

        def timed(name, fn):
            def wrapper(*a, **k):
                if name == MAIN and stack:  # a render inside another phase (a background, a pass) is that phase's
                    return fn(*a, **k)
                flush(time.perf_counter())
                stack.append([name, time.perf_counter(), 0.0])
                try:
                    return fn(*a, **k)
                finally:
                    now = time.perf_counter()
                    flush(now)
                    _, start, inner = stack.pop()
                    spent[name] += now - start - inner
                    if stack:
                        stack[-1][2] += now - start
            return wrapper

        bpy.app.handlers.render_stats.append(stats)
        rp.apply_state = timed("scene state (deformation, pose, materials, world)", rp.apply_state)
        rp.render_to_array = timed(MAIN, rp.render_to_array)
        rp._render_background = timed("white and black backgrounds", rp._render_background)
        rp._save = timed("deformsim's image writes", rp._save)
        for f in ctx.features:
            name = type(f).__name__
            f.image = timed(f"{name}: work on each image", f.image)
            if f.extra_pass:
                f.render_pass = timed(f"{name}: extra pass ({', '.join(f.kinds)})", f.render_pass)
        wall = 0.0
        for i in range(args.states + 1):
            p = sample_params(i, cfg.generate.seed, cfg, spec, hdris)
            if i == 0:
                rp.render_sample(ctx, p, layout)  # warm-up
                spent.clear()
                cycles.clear()
                lines.clear()
                continue
            t0 = time.perf_counter()
            rp.render_sample(ctx, p, layout)
            wall += time.perf_counter() - t0
        bpy.app.handlers.render_stats.remove(stats)
        n = args.states
        print(f"{cfg.render.resolution} px, {cfg.render.samples} spp, {len(ctx.cameras)} cameras, {args.threads} threads, "
              f"{reply['device']}; setup {setup:.1f} s; {n} samples timed after one warm-up: {wall / n:.2f} s per sample")
        spent["other (camera placement, ...)"] = wall - sum(spent.values())
        print("| phase | s per sample | share of wall |\n|---|---|---|")
        for k, v in sorted(spent.items(), key=lambda kv: -kv[1]):
            print(f"| {k} | {v / n:.2f} | {100 * v / wall:.0f} % |")
            for phase, t in sorted(cycles.get(k, {}).items(), key=lambda kv: -kv[1]):
                print(f"| - of which Cycles {phase} | {t / n:.2f} | {100 * t / wall:.0f} % |")
        print("\nCycles' slowest steps, every render call together:\n| status line | s per sample |\n|---|---|")
        for line, t in sorted(lines.items(), key=lambda kv: -kv[1])[:10]:
            print(f"| {line} | {t / n:.2f} |")


if __name__ == "__main__":
    run_main(main)
