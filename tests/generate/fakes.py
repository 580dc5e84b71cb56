"""Fake render workers for tests of the driver (resume, refusal, signals, a full disk) that need no Blender."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

from deformsim.generate.worker_client import WorkerCrashed, WorkerProcess, worker_env

FAKE_WORKER = Path(__file__).with_name("fake_worker.py")


class FakeWorker(WorkerProcess):
    """A :class:`WorkerProcess` that starts ``fake_worker.py`` instead of Blender."""

    def start(self, setup: dict, timeout: float | None = 300) -> dict:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "ab") as log:
            self.proc = subprocess.Popen([sys.executable, str(FAKE_WORKER)], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, stderr=log, env=worker_env(self.threads))
        threading.Thread(target=self._read, args=(self.proc.stdout,), daemon=True).start()
        reply = self._ask({"setup": setup}, timeout)
        if not reply.get("ready"):
            raise WorkerCrashed(str(reply))
        return reply


def use_fakes(monkeypatch, mode: str = "ok", probe_size=(0.07, 0.07, 0.19)) -> None:
    """Render with fake workers in ``mode``; a mesh probe that reports ``probe_size`` (metres)."""
    from deformsim.generate import local, stage

    monkeypatch.setenv("FAKE_WORKER_MODE", mode)
    monkeypatch.setattr(local, "WorkerProcess", FakeWorker)
    monkeypatch.setattr(stage, "probe_mesh", lambda mesh, spec, timeout=300: {"size": list(probe_size), "vertices": 8})


if __name__ == "__main__":  # python tests/generate/fakes.py ARGS: the deformsim command line on fake workers
    from deformsim.cli.app import app
    from deformsim.generate import local

    local.WorkerProcess = FakeWorker
    app(sys.argv[1:], prog_name="deformsim")
