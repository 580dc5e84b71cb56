"""What identity by content costs: the share of a cached `deformsim run` (every stage skipped) spent hashing.

    python bench/identity.py [--repeat N] [--no-mesh]

Builds run folders whose stages are all up to date (the stages are stubbed: a cached run reads only their
stamps and outputs), then measures on each
- the wall time of `deformsim run` as a user sees it: a fresh process, N times, the median; and
- the time that run spends hashing its inputs by content (mesh bytes, parsed spec, background and real photos),
  in process with nothing remembered (every digest computed from the bytes, as in a fresh process), N times,
  the median,
for the built-in can and for a user mesh (the carton; checking it starts Blender once), with the development
photos as backgrounds and real set when they are beside the checkout. Prints the ratio; the target is < 2 %.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _util import ROOT, SHARED, positive_int, run_main

from deformsim import identity
from deformsim.atomic import write_json, write_text
from deformsim.config import dump_config, load_config
from deformsim.dataset.layout import Layout
from deformsim.generate import identity as gen_identity
from deformsim.generate import stage as gen_stage


def stub_stages() -> None:
    """Stages that write only what a cached run looks at."""
    from deformsim.composite import stage as comp_stage
    from deformsim.evaluate import experiments
    from deformsim.report import html

    def generate(cfg, data, progress=True, prepared=None, overwrite=False):
        layout = Layout(data)
        data.mkdir(parents=True, exist_ok=True)
        write_json(layout.inputs, {"kind": "dataset", "inputs": gen_identity.input_digests(cfg), "files": {}})
        write_text(layout.config, dump_config(cfg))
        layout.manifest.write_bytes(b"")

    def composite(data, cfg, name, seed, progress=True):
        (data / "variants" / name).mkdir(parents=True, exist_ok=True)
        (data / "variants" / name / "manifest.parquet").write_bytes(b"")

    def write_report(metrics, out):
        (Path(out) / "report.html").write_text("")

    gen_stage.generate = generate
    comp_stage.composite = composite
    experiments.run_experiments = lambda *a, **k: {}
    html.write_report = write_report


class HashClock:
    """Wall time inside the content-hashing functions (outermost calls only), with their memo emptied first."""

    def __init__(self):
        self.seconds, self._depth = 0.0, 0

    def wrap(self, module, name: str) -> None:
        fn = getattr(module, name)

        def timed(*args, **kwargs):
            self._depth += 1
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self._depth -= 1
                if self._depth == 0:
                    self.seconds += time.perf_counter() - t0

        setattr(module, name, timed)


def hashing_seconds(cfg, out: Path, real: Path | None, repeat: int) -> tuple[float, list[str]]:
    """Median time a cached in-process run spends hashing (digests computed afresh each time)."""
    from deformsim import pipeline
    from deformsim.report import stage as report_stage

    clock = HashClock()
    clock.wrap(gen_identity, "input_digests")
    clock.wrap(pipeline, "files_digest")
    clock.wrap(report_stage, "files_digest")
    times, skipped = [], []
    for _ in range(repeat):
        identity._MEMO.clear()
        clock.seconds = 0.0
        skipped = pipeline.run(cfg, out, real=real, progress=False).skipped
        times.append(clock.seconds)
    return statistics.median(times), skipped


def cli_seconds(args: list[str], repeat: int) -> float:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "deformsim.cli", "run", *args, "--no-progress"], cwd=ROOT,
                              env=env, capture_output=True, text=True)
        times.append(time.perf_counter() - t0)
        if proc.returncode != 0 or "up to date, skipped: generate" not in proc.stdout or "s\n" in proc.stdout:
            raise SystemExit(f"the run was not fully cached:\n{proc.stdout}\n{proc.stderr}")
    return statistics.median(times)


def scenario(name: str, overrides: dict, flags: list[str], real: Path | None, tmp: Path, repeat: int) -> float:
    from deformsim.pipeline import run

    cfg = load_config("quick", overrides)
    out = tmp / name
    run(cfg, out, real=real, progress=False)  # stubbed stages: every stamp recorded
    hashing, skipped = hashing_seconds(cfg, out, real, repeat)
    args = ["--out", str(out), *flags] + (["--real", str(real)] if real else [])
    wall = cli_seconds(args, repeat)
    share = hashing / (wall - hashing)
    print(f"{name:<28} cached `deformsim run` {wall * 1000:7.0f} ms (skipped: {', '.join(skipped)}); "
          f"hashing {hashing * 1000:6.1f} ms = {100 * share:.2f} % added")
    return share


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=positive_int, default=5)
    parser.add_argument("--no-mesh", action="store_true", help="skip the user-mesh case (it starts Blender)")
    args = parser.parse_args()
    backgrounds, real = SHARED / "backgrounds", SHARED / "real_cans_dev"
    backgrounds = backgrounds.resolve() if backgrounds.is_dir() else None
    real = real.resolve() if real.is_dir() else None
    mb = sum(p.stat().st_size for d in (backgrounds, real) if d for p in d.rglob("*") if p.is_file()) / 2**20
    print(f"photos hashed per run: {mb:.1f} MB ({'development data' if real else 'none found: procedural only'})")
    stub_stages()
    shares = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        bg = {"composite.backgrounds": backgrounds} if backgrounds else {}
        bg_flag = ["--backgrounds", str(backgrounds)] if backgrounds else []
        shares.append(scenario("built-in can", bg, bg_flag, real, tmp, args.repeat))
        if not args.no_mesh:
            mesh, spec = tmp / "carton.stl", ROOT / "examples" / "carton" / "spec.yaml"
            subprocess.run([sys.executable, str(ROOT / "examples" / "carton" / "make_carton.py"), str(mesh)], check=True)
            over = {**bg, "object.mesh": mesh, "object.spec": spec}
            flags = [*bg_flag, "--object", str(mesh), "--spec", str(spec)]
            shares.append(scenario(f"carton.stl ({mesh.stat().st_size / 2**20:.1f} MB)", over, flags, real, tmp,
                                   args.repeat))
    worst = max(shares)
    print(f"hashing adds at most {100 * worst:.2f} % to a cached run (target < 2 %): {'ok' if worst < 0.02 else 'OVER'}")


if __name__ == "__main__":
    run_main(main)
