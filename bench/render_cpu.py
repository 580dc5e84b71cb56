"""CPU seconds of a render worker per sample under several render settings, the same samples for each (robust to
other load on the machine, unlike wall time): the ratio of each setting to the first.

    python bench/render_cpu.py --object runs/tins/tin.stl --states 0,2,4 \\
        'base={}' 'spp8={"render.samples": 8}' 'fast={"render.denoise_prefilter": "fast"}'

Defaults to the tin example (examples/tin/config.yaml and spec.yaml); one Cycles thread per worker.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from _util import ROOT, run_main


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("settings", nargs="+", help="NAME=JSON of dotted overrides; the first is the baseline")
    ap.add_argument("--config", type=Path, default=ROOT / "examples" / "tin" / "config.yaml")
    ap.add_argument("--spec", type=Path, default=ROOT / "examples" / "tin" / "spec.yaml")
    ap.add_argument("--object", type=Path, required=True, help="the part's mesh (examples/tin/make_tin.py makes the tin)")
    ap.add_argument("--states", default="0,2,4", help="comma-separated sample indices, seed 0")
    args = ap.parse_args()
    import numpy as np

    from deformsim.config import load_config
    from deformsim.generate.worker_client import WorkerProcess
    from deformsim.hdri import list_hdris
    from deformsim.sampling import sample_params
    from deformsim.spec.model import load_spec

    settings = {name: json.loads(value) for name, _, value in (s.partition("=") for s in args.settings)}
    states = [int(s) for s in args.states.split(",")]
    base = {"object.mesh": str(args.object), "object.spec": str(args.spec)}
    seconds: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory(prefix="deformsim-bench-") as tmp:
        for name, overrides in settings.items():
            cfg = load_config(args.config, {**base, **overrides})
            spec, hdris = load_spec(cfg.object.spec), list_hdris(None)
            worker = WorkerProcess(Path(tmp) / f"{name}.log", threads=1)
            worker.start({"config": cfg.model_dump(mode="json"), "spec_path": str(cfg.object.spec),
                          "out": str(Path(tmp) / name), "bank": None})
            try:
                for i in states:
                    p = sample_params(i, 0, cfg, spec, hdris)
                    cpu, wall = _cpu_seconds(worker.pid), time.perf_counter()
                    reply = worker.render(p.to_dict())
                    if "error" in reply:
                        raise SystemExit(f"{name}: sample {i} failed: {reply['message']}")
                    seconds.setdefault(name, []).append(_cpu_seconds(worker.pid) - cpu)
                    print(f"{name} sample {i}: {seconds[name][-1]:.2f} CPU s ({time.perf_counter() - wall:.2f} s wall)",
                          flush=True)
            finally:
                worker.close()
    first = np.mean(next(iter(seconds.values())))
    print("| setting | CPU s per sample | speed against the first |\n|---|---|---|")
    for name, s in seconds.items():
        print(f"| {name} | {np.mean(s):.1f} | {first / np.mean(s):.2f}x |")


if __name__ == "__main__":
    run_main(main)
