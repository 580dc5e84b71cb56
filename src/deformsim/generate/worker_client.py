"""Drive Blender render workers (``python -m deformsim.blender.worker``) from a bpy-free process.

The protocol is JSON lines on the worker's stdin/stdout (see :mod:`deformsim.blender.worker`); the
worker's stderr (Blender's own output included) goes to a log file.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
from pathlib import Path

SRC_DIR = Path(__file__).resolve().parents[2]  # the folder holding the deformsim package


class WorkerCrashed(RuntimeError):
    """The worker died, closed its output, failed to start, or did not answer in time."""


def worker_env(threads: int = 0) -> dict:
    """This environment, with this package importable and ``threads`` for the math libraries when set."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC_DIR), env.get("PYTHONPATH")]))
    if threads:
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env[var] = str(threads)
    return env


class WorkerProcess:
    """One render worker. ``start`` builds its scene; ``render`` renders one sample; ``close`` quits it."""

    def __init__(self, log_path: str | Path, threads: int = 0):
        self.log_path = Path(log_path)
        self.threads = threads
        self.proc: subprocess.Popen | None = None
        self._lines: queue.Queue = queue.Queue()

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc else None

    def start(self, setup: dict, timeout: float | None = 300) -> dict:
        """Spawn the worker and send ``setup``; return its ready reply (device, camera_scale, ...)."""
        env = worker_env(self.threads)
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "ab") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "deformsim.blender.worker"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=log,
                env=env,
            )
        threading.Thread(target=self._read, args=(self.proc.stdout,), daemon=True).start()
        reply = self._ask({"setup": {**setup, "threads": self.threads}}, timeout)
        if not reply.get("ready"):
            self.kill()
            raise WorkerCrashed(f"worker setup failed: {reply.get('message', reply)} (log: {self.log_path})")
        return reply

    def render(self, params: dict, timeout: float | None = None) -> dict:
        """Render one sample: a :class:`~deformsim.dataset.rendered.Rendered` dict (``{"done": i, ...}``) or
        ``{"error": i, "message": ...}``."""
        return self._ask({"render": params}, timeout)

    def configure(self, render: dict, timeout: float | None = 60) -> dict:
        """New render settings (a RenderConfig dict) for the built scene: ``{"configured": device}``."""
        return self._ask({"configure": render}, timeout)

    def close(self, timeout: float = 30) -> None:
        """Ask the worker to quit; kill it if it does not within ``timeout`` seconds."""
        if self.proc is None:
            return
        try:
            self._send({"quit": True})
            self.proc.wait(timeout)
        except (WorkerCrashed, subprocess.TimeoutExpired):
            self.kill()
        self.proc = None

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def _read(self, stream) -> None:
        for line in stream:
            self._lines.put(line)
        self._lines.put(None)  # EOF: the worker exited or was killed

    def _send(self, msg: dict) -> None:
        if self.proc is None or self.proc.poll() is not None:
            raise WorkerCrashed(self._died())
        try:
            self.proc.stdin.write((json.dumps(msg) + "\n").encode())
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            raise WorkerCrashed(self._died()) from None

    def _ask(self, msg: dict, timeout: float | None) -> dict:
        self._send(msg)
        try:
            line = self._lines.get(timeout=timeout)
        except queue.Empty:
            self.kill()
            raise WorkerCrashed(f"worker {self.pid} did not answer within {timeout} s (log: {self.log_path})") from None
        if line is None:
            raise WorkerCrashed(self._died())
        try:
            return json.loads(line)
        except ValueError:
            self.kill()
            raise WorkerCrashed(f"worker {self.pid} sent a malformed reply: {line[:200]!r}") from None

    def _died(self) -> str:
        code = None
        if self.proc is not None:
            try:
                code = self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.kill()
                code = self.proc.returncode
        tail = _tail(self.log_path)
        return f"worker exited with code {code} (log: {self.log_path}){': ' + tail if tail else ''}"


def _tail(path: Path, n: int = 300) -> str:
    try:
        text = path.read_text(errors="replace").strip()
    except OSError:
        return ""
    return " ".join(text[-n:].split())
