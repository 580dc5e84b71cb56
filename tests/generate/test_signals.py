"""SIGTERM to the driver behaves like Ctrl-C with real Blender workers."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from tests.generate.test_refusals import _alive
from tests.util import ROOT, child_pids


@pytest.mark.blender
def test_sigterm_stops_blender_workers_at_once(tmp_path):
    out = tmp_path / "D"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.Popen([sys.executable, "-m", "deformsim.cli", "generate", "--out", str(out), "--n", "32",
                             "--resolution", "64", "--samples", "4", "--workers", "2", "--no-progress"],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    logs = [out / "logs" / f"worker{w}.log" for w in (0, 1)]
    t0 = time.time()
    while not all(p.is_file() and "ready on" in p.read_text(errors="replace") for p in logs):
        assert proc.poll() is None and time.time() - t0 < 300, proc.communicate()
        time.sleep(0.2)
    workers = child_pids(proc.pid)
    assert len(workers) == 2
    t_term = time.time()
    proc.send_signal(signal.SIGTERM)  # the driver only
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "terminated" in err and "Traceback" not in err, err
    while any(_alive(pid) for pid in workers) and time.time() - t_term < 5:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers), "a Blender worker kept running after SIGTERM"
    assert time.time() - t_term < 5
    assert not list((out / "images").rglob(".*"))  # no partial render left
