"""Memory: the peak of the commands a hostile size could blow up, against their 2 GB targets, and a Blender worker's
memory over a long run.

``targets`` (each command in its own process; the peak is its resident high-water mark, VmHWM, which unlike
``ru_maxrss`` a child does not inherit from this process):

- ``predict`` with a model whose saved config has ``image_size: 1024`` (VGG-16, the default backbone; its weights do
  not change the memory) on 29 photos of ``../shared/data/real_cans_dev`` (generated images when it is absent);
- ``bench bag -k 2`` on a synthetic results file of 200 000 photos (4 runs of one draw);
- ``generate --n 10000000 --yes`` up to its first render: the worker is a stand-in that stops the run when it is
  handed its first sample, so the peak is that of planning.

``worker``: resident memory of one Blender worker rendering 320 tiny images, after the first sample and after the
last, with and without recycling (``generate.recycle_every``: the orchestrator restarts a worker every K images).

Usage: ``python bench/memory.py [targets|worker]`` (default: both).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, SHARED, rss_mb

TARGET_MIB = 2048
PHOTOS = 29
BAG_PHOTOS = 200_000

# Runs the CLI in this process and prints its peak resident memory (KiB) on the last line of stderr.
PEAK = """
import runpy, sys
sys.argv = ["deformsim", *sys.argv[1:]]
try:
    runpy.run_module("deformsim.cli", run_name="__main__")
finally:
    print("peak-kib", [l.split()[1] for l in open("/proc/self/status") if l.startswith("VmHWM")][0], file=sys.stderr)
"""

# generate with a stand-in worker that ends the process (printing the peak) when handed its first sample.
FIRST_RENDER = """
import os, sys, threading
from deformsim.generate import local

FIRST = threading.Lock()  # the workers' threads race: one reports, whole lines, and ends the process

class FirstRender:
    pid = 0
    def __init__(self, *args, **kwargs): pass
    def start(self, setup, timeout=None): return {"device": "stand-in", "camera_scale": 1.0}
    def render(self, params):
        with FIRST:
            hwm = [l.split()[1] for l in open("/proc/self/status") if l.startswith("VmHWM")][0]
            sys.stderr.write(f"first sample {params['index']}\\npeak-kib {hwm}\\n")
            sys.stderr.flush()
            os._exit(0)
    def close(self): pass
    kill = close

local.WorkerProcess = FirstRender
from deformsim.cli.app import app
app(sys.argv[1:], prog_name="deformsim")
"""


def _peak(code: str, args: list, work: Path) -> tuple[float, float]:
    """(peak MiB, seconds) of ``python -c code args`` with this checkout's code and a cache under ``work``."""
    env = {**os.environ, "PYTHONPATH": f"{ROOT / 'src'}{os.pathsep}{ROOT}", "DEFORMSIM_CACHE": str(work / "cache")}
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=work, env=env, capture_output=True,
                          text=True)
    seconds = time.perf_counter() - t0
    lines = done.stderr.strip().splitlines()
    if done.returncode != 0 or not lines or not lines[-1].startswith("peak-kib"):
        raise SystemExit(f"{args[0]} failed (exit {done.returncode}): {' | '.join(lines[-3:])}")
    return int(lines[-1].split()[1]) / 1024, seconds


def _photos(work: Path) -> tuple[list[Path], str]:
    real = SHARED / "real_cans_dev"
    found = sorted(p for p in real.rglob("*") if p.suffix.lower() in (".jpg", ".jpeg", ".png")) if real.is_dir() else []
    if len(found) >= PHOTOS:
        step = len(found) / PHOTOS
        return [found[int(i * step)] for i in range(PHOTOS)], str(real)
    import numpy as np
    from PIL import Image

    rng = np.random.default_rng(0)
    (work / "photos").mkdir()
    paths = [work / "photos" / f"{i}.jpg" for i in range(PHOTOS)]
    for p in paths:
        Image.fromarray(rng.integers(0, 255, (1200, 1600, 3), dtype=np.uint8)).save(p)
    return paths, "generated 1600x1200 images"


def predict_1024(work: Path) -> tuple[float, float, str]:
    from deformsim.config import TrainConfig
    from deformsim.learn import checkpoint
    from deformsim.learn.models import build

    cfg = TrainConfig(weights="none", image_size=1024)
    model, _ = build(cfg, load_weights=False)
    (work / "model").mkdir()
    checkpoint.save(work / "model" / "model.pt", model, cfg, "none", [], {})
    photos, source = _photos(work)
    peak, seconds = _peak(PEAK, ["predict", work / "model", *photos, "--csv", work / "p.csv"], work)
    return peak, seconds, f"{cfg.backbone} at 1024 px, batch_size {cfg.batch_size}, {len(photos)} photos ({source})"


def bag_200k(work: Path) -> tuple[float, float, str]:
    import numpy as np

    from deformsim.config import Config

    rng = np.random.default_rng(0)
    y = (rng.random(BAG_PHOTOS) < 0.5).astype(int)
    runs = []
    for seed in range(4):
        prob = np.clip(y * 0.3 + rng.random(BAG_PHOTOS) * 0.7, 0, 1).round(4)
        runs.append({"variant": "backgrounds", "data_seed": 0, "composite_seed": 0, "train_seed": seed,
                     "model": f"models/{seed}", "real": {"accuracy": 0.8, "f1": 0.8, "precision": 0.8, "recall": 0.8,
                                                         "auc": 0.9, "confusion": [[1, 1], [1, 1]]},
                     "synthetic": {"accuracy": 0.9, "f1": 0.9}, "real_predictions": prob.tolist()})
    results = {"real_dir": "/photos", "real_images": BAG_PHOTOS, "majority_baseline": 0.5,
               "real_paths": [f"/photos/{'deformed' if v else 'intact'}/{i}.jpg" for i, v in enumerate(y)],
               "real_labels": y.tolist(), "settings": Config().model_dump(mode="json"), "runs": runs}
    (work / "results.json").write_text(json.dumps(results))
    peak, seconds = _peak(PEAK, ["bench", "bag", work / "results.json", "-k", "2", "--out", work / "bagged"], work)
    return peak, seconds, f"{BAG_PHOTOS:,} photos x 4 runs, --members 2"


def generate_1e7(work: Path) -> tuple[float, float, str]:
    peak, seconds = _peak(FIRST_RENDER, ["generate", "--out", work / "data", "--n", "10000000", "--yes",
                                         "--no-progress"], work)
    return peak, seconds, "up to the first sample handed to a worker"


def targets() -> None:
    for name, measure in (("predict, image_size 1024", predict_1024), ("bench bag, 200k photos", bag_200k),
                          ("generate --n 1e7 --yes", generate_1e7)):
        with tempfile.TemporaryDirectory() as tmp:
            peak, seconds, what = measure(Path(tmp))
        verdict = "under" if peak < TARGET_MIB else "OVER"
        print(f"{name:>26}: peak {peak:,.0f} MiB in {seconds:.0f} s, {verdict} the {TARGET_MIB:,} MiB target ({what})",
              flush=True)


IMAGES = 320
RECYCLE = 100


def run_worker(recycle_every: int) -> tuple[float, float, float, float]:
    from deformsim.config import load_config
    from deformsim.dataset.layout import Layout
    from deformsim.generate.backend import worker_setup
    from deformsim.generate.stage import prepare
    from deformsim.generate.worker_client import WorkerProcess
    from deformsim.sampling import sample_params

    cfg = load_config("quick", {"generate.n": IMAGES, "render.resolution": 32, "render.samples": 1,
                                "render.denoise": False, "generate.recycle_every": recycle_every})
    with tempfile.TemporaryDirectory() as tmp:
        spec, hdris = prepare(cfg, Path(tmp))
        layout = Layout(Path(tmp))
        worker, rendered, first, peak = None, 0, None, 0.0
        t0 = time.perf_counter()
        for i in range(IMAGES // 4):
            if worker is None or rendered >= recycle_every:
                if worker is not None:
                    worker.close()
                worker = WorkerProcess(log_path=Path(tmp) / "w.log", threads=2)
                worker.start(worker_setup(cfg, layout))
                rendered = 0
            reply = worker.render(sample_params(i, 0, cfg, spec, hdris).to_dict())
            assert "done" in reply, reply
            rendered += 4
            rss = rss_mb(worker.pid)
            first = first or rss
            peak = max(peak, rss)
        end = rss_mb(worker.pid)
        worker.close()
        return first, end, peak, time.perf_counter() - t0


def worker() -> None:
    for label, k in (("no recycling", 10**9), (f"recycle every {RECYCLE}", RECYCLE)):
        first, end, peak, secs = run_worker(k)
        print(f"{label:>20}: {IMAGES} images in {secs:.0f} s; RSS start {first:.0f} MiB, end {end:.0f} MiB, "
              f"peak {peak:.0f} MiB, end/start ratio {end / first:.3f}")


if __name__ == "__main__":
    parts = {"targets": targets, "worker": worker}
    which = sys.argv[1:] or list(parts)
    if unknown := [w for w in which if w not in parts]:
        raise SystemExit(f"error: unknown part {unknown[0]!r} (choose from {', '.join(parts)})")
    for part in which:
        parts[part]()
