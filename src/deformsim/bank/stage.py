"""Baking a bank: simulate every scenario variant of a spec once, in a Blender process, and cache it."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from deformsim.atomic import write_json
from deformsim.bank.store import bank_dir, bank_key, is_complete
from deformsim.errors import UserError
from deformsim.extras import require
from deformsim.generate.worker_client import worker_env
from deformsim.log import get_logger, progress_bar
from deformsim.outputs import replacing
from deformsim.spec.model import Spec
from deformsim.spec.simulation import entry_names

log = get_logger(__name__)


def bake(spec: Spec, spec_path: str | Path | None, mesh: str | Path | None, progress: bool = True,
         force: bool = False) -> Path:
    """The bank folder of ``spec`` on ``mesh`` (None: the built-in part), simulated now unless cached.

    A scenario whose simulation explodes or does not converge raises a one-line UserError naming it, and
    nothing is cached; ``force`` bakes again even when a complete bank is cached.
    """
    if spec.simulation is None:
        raise UserError(f"spec '{spec.name}' declares no simulation scenarios: nothing to bake")
    final = bank_dir(spec, mesh)
    if is_complete(final, spec) and not force:
        log.info("bank: reusing %s", final)
        return final
    require("render", what="baking the simulated bank")
    names = entry_names(spec.simulation)
    # the old bank (force) goes only once the new one is complete; one that another process baked meanwhile stays
    with replacing(final, keep=lambda: is_complete(final, spec) and not force) as work:
        entries, positions = _simulate(spec_path, mesh, work, len(names), progress)
        np.savez(work / "bank.npz", positions=np.stack(positions), names=np.array(names))
        write_json(work / "bank.json", {"spec": spec.name, "key": bank_key(spec, mesh),
                                        "mesh": str(mesh) if mesh else None, "entries": entries})
        for f in work.glob("[0-9]*.npy"):
            f.unlink()
    total = sum(e["stats"]["seconds"] for e in entries)
    log.info("bank: %d entries baked in %.0f s (%.1f s each) into %s", len(entries), total, total / len(entries), final)
    return final


def _simulate(spec_path, mesh, work: Path, total: int, progress: bool) -> tuple[list[dict], list[np.ndarray]]:
    req = {"spec_path": str(spec_path) if spec_path else None, "mesh": str(mesh) if mesh else None, "out": str(work)}
    log_file = open(work / "bake.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "deformsim.blender.bake"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=log_file, text=True, env=worker_env())
    bar = progress_bar(total=total, desc="bake", enabled=progress)
    entries, positions, t0 = [], [], time.perf_counter()
    try:
        proc.stdin.write(json.dumps(req) + "\n")
        proc.stdin.close()
        for line in proc.stdout:
            msg = json.loads(line)
            if "error" in msg:
                raise UserError(f"bake: {msg['error']}; nothing was cached")
            positions.append(np.load(msg["file"]))
            entries.append({"name": msg["entry"], "variant": msg["variant"], "stats": msg["stats"]})
            bar.update(1)
    except BaseException:
        proc.kill()
        raise
    finally:
        bar.close()
        proc.wait()
        log_file.close()
    if proc.returncode != 0 or len(entries) != total:
        tail = (work / "bake.log").read_text(errors="replace")[-600:].strip().splitlines()
        raise RuntimeError(f"bake process failed ({proc.returncode}) after {len(entries)} of {total} entries "
                           f"in {time.perf_counter() - t0:.0f} s: {tail[-1] if tail else 'no output'}")
    return entries, positions
