"""Helpers shared by the benchmarks (run them from the repository root with the project's venv)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
SHARED = ROOT.parent / "shared" / "data"


def run_main(main) -> None:
    """Run a benchmark's ``main``: bad input (a UserError) ends it with ``error: <message>``, one line, as in the
    CLI, rather than a traceback."""
    from deformsim.errors import UserError

    try:
        main()
    except UserError as exc:
        raise SystemExit(f"error: {exc}") from None


def positive_int(text: str) -> int:
    """An argparse type: a whole number of at least 1."""
    import argparse

    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of at least 1, got {text!r}")
    return int(text)


def rss_mb(pid: int) -> float:
    """Resident memory of a process in MiB (Linux)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for {pid}")


def render_options(ap) -> None:
    """The command-line options of the interleaved render benchmarks (dense, scene)."""
    ap.add_argument("--states", type=positive_int, default=4, help="timed samples (4 images each)")
    ap.add_argument("--resolution", type=positive_int, default=128)
    ap.add_argument("--samples", type=positive_int, default=16)
    ap.add_argument("--threads", type=int, default=2)


def interleaved_seconds(cfgs: dict, params: dict, threads: int) -> tuple[dict, int]:
    """Seconds per image of one worker per config in ``cfgs``, rendering ``params[key]`` (lists of equal length)
    in turn (sample j of every config, then j + 1), so machine load falls on all alike. Each first sample warms
    its worker up and is not counted. Returns (seconds per image per key, images timed per key)."""
    import tempfile
    import time

    from deformsim.dataset.layout import Layout
    from deformsim.generate.backend import worker_setup
    from deformsim.generate.worker_client import WorkerProcess

    wall = {k: 0.0 for k in cfgs}
    images = {k: 0 for k in cfgs}
    with tempfile.TemporaryDirectory() as tmp:
        workers = {k: WorkerProcess(Path(tmp) / f"{k}.log", threads=threads) for k in cfgs}
        try:
            for k, w in workers.items():
                w.start(worker_setup(cfgs[k], Layout(Path(tmp) / str(k))))
            for j in range(len(next(iter(params.values())))):
                for k, w in workers.items():
                    p = params[k][j]
                    t0 = time.perf_counter()
                    reply = w.render(p.to_dict())
                    if "error" in reply:
                        raise SystemExit(f"{k}: sample {p.index} failed: {reply['message']}")
                    if j:
                        wall[k] += time.perf_counter() - t0
                        images[k] += len(p.cameras)
        finally:
            for w in workers.values():
                w.close()
    n = next(iter(images.values()))
    return {k: wall[k] / images[k] for k in cfgs}, n
