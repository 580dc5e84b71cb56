"""Drive Blender render workers (``python -m deformsim.blender.worker``) from a bpy-free process.

The protocol is JSON lines on the worker's stdin/stdout (see :mod:`deformsim.blender.worker`); the
worker's stderr (Blender's own output included) goes to a log file.
"""

from __future__ import annotations

import importlib.util
import json
import os
import queue
import subprocess
import sys
import threading
from pathlib import Path

from deformsim.errors import UserError

HDRI_SUFFIXES = (".exr", ".hdr")
SRC_DIR = Path(__file__).resolve().parents[1]


class WorkerCrashed(RuntimeError):
    """The worker died, closed its output, failed to start, or did not answer in time."""


def blender_hdri_dir() -> Path:
    """Blender's bundled studio-light HDRIs, found without importing bpy."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise UserError("the bpy package is not installed: cannot find Blender's HDRIs (set lighting.hdri_dir)")
    for root in spec.submodule_search_locations:
        found = sorted(Path(root).glob("*/datafiles/studiolights/world"))
        if found:
            return found[-1]
    raise UserError("Blender's studiolights/world folder was not found in the bpy package (set lighting.hdri_dir)")


def hdri_files(hdri_dir: Path | None) -> dict[str, Path]:
    """HDRI name (file stem) -> path; Blender's studio lights (*.exr) when ``hdri_dir`` is None."""
    if hdri_dir is None:
        return {p.stem: p for p in sorted(blender_hdri_dir().glob("*.exr"))}
    hdri_dir = Path(hdri_dir)
    if not hdri_dir.is_dir():
        raise UserError(f"lighting.hdri_dir {hdri_dir} is not a folder")
    files = sorted(p for p in hdri_dir.iterdir() if p.is_file() and p.suffix.lower() in HDRI_SUFFIXES)
    if not files:
        raise UserError(f"lighting.hdri_dir {hdri_dir} holds no .exr or .hdr file")
    stems = [p.stem for p in files]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise UserError(f"lighting.hdri_dir {hdri_dir}: several files named {', '.join(dup)} (rename one)")
    return {p.stem: p for p in files}


def list_hdris(hdri_dir: Path | str | None) -> list[str]:
    """Names of the available HDRIs, sorted; the same names the worker's world uses."""
    names = sorted(hdri_files(Path(hdri_dir) if hdri_dir is not None else None))
    if not names:
        raise UserError("no HDRI found in Blender's studio lights (set lighting.hdri_dir)")
    return names


def probe_mesh(mesh: Path, spec_path: Path | None, timeout: float = 300) -> dict:
    """Import ``mesh`` in a throwaway Blender process; its size, or a UserError naming the problem."""
    args = [sys.executable, "-m", "deformsim.blender.mesh_import", str(mesh)] + ([str(spec_path)] if spec_path else [])
    proc = subprocess.run(args, capture_output=True, text=True, env=_worker_env(), timeout=timeout)
    if proc.returncode == 2:
        raise UserError(proc.stderr.strip().splitlines()[-1])
    if proc.returncode != 0:
        raise RuntimeError(f"mesh probe failed ({proc.returncode}): {' '.join(proc.stderr.split()[-60:])}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _worker_env(threads: int = 0) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC_DIR), env.get("PYTHONPATH")]))
    if threads:
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env[var] = str(threads)
    return env


class WorkerProcess:
    """One render worker. ``start`` builds its scene; ``render`` renders one sample; ``close`` quits it."""

    def __init__(self, log_path: str | Path, threads: int = 0, python: str | None = None):
        self.log_path = Path(log_path)
        self.threads = threads
        self.python = python or sys.executable
        self.proc: subprocess.Popen | None = None
        self._lines: queue.Queue = queue.Queue()

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc else None

    def start(self, setup: dict, timeout: float | None = 300) -> dict:
        """Spawn the worker and send ``setup``; return its ready reply (device, camera_scale, ...)."""
        env = _worker_env(self.threads)
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "ab") as log:
            self.proc = subprocess.Popen(
                [self.python, "-m", "deformsim.blender.worker"],
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
        """Render one sample: ``{"done": i, "render_seconds": [...]}`` or ``{"error": i, "message": ...}``."""
        return self._ask({"render": params}, timeout)

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
