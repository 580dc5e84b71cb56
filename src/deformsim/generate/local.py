"""Render on this machine: a pool of threads, each driving one Blender worker process.

Ctrl-C and SIGTERM (raised as KeyboardInterrupt by the command line) kill every worker at once and remove the
partial files; a full disk stops the whole run with one line instead of failing every sample.
"""

from __future__ import annotations

import errno
import threading

from deformsim.config import Config
from deformsim.dataset.layout import Layout
from deformsim.dataset.rendered import Rendered
from deformsim.errors import ResourceError, UserError
from deformsim.generate.backend import (
    Retries,
    Todo,
    disk_full,
    finish_sample,
    log_sizes,
    remove_partial_files,
    render_workers,
    worker_setup,
)
from deformsim.generate.worker_client import WorkerCrashed, WorkerProcess
from deformsim.log import get_logger, progress_bar
from deformsim.parallel import cores_per_worker

log = get_logger(__name__)


def run_local(cfg: Config, layout: Layout, todo: Todo, progress: bool) -> tuple[dict[int, str], str]:
    """Render the samples of ``todo`` with local worker processes; returns (failed samples with reasons, device)."""
    n_workers = render_workers(cfg, len(todo))
    threads = cfg.render.threads or cores_per_worker(n_workers)
    views = len(cfg.camera.azimuth_quadrants)
    retries = Retries(cfg.generate.max_retries)
    stop = threading.Event()
    lock = threading.Lock()
    remaining = [len(todo)]
    device = [""]
    errors: list = []  # what stopped the run: a message, or an error to raise as it is
    live: dict[int, object] = {}  # worker slot -> running WorkerProcess, killed on Ctrl-C
    logs = layout.root / "logs"
    logs.mkdir(exist_ok=True)
    since = log_sizes(layout)
    bar = progress_bar(total=len(todo) * views, desc="render", enabled=progress)

    def retry_or_fail(i: int, reason: str) -> None:
        full = disk_full(layout, reason, since=since)
        if full is not None:  # every other sample would fail the same way
            with lock:
                errors.append(full)
            stop.set()
            return
        with lock:
            if retries.retry(i, reason):
                todo.again(i)
            else:
                remaining[0] -= 1

    def run_worker(w: int) -> None:
        proc = None
        rendered = 0
        try:
            while not stop.is_set():
                with lock:
                    if remaining[0] <= 0:
                        return
                i = todo.take()
                if i is None:  # every sample handed out; a retry may still come
                    stop.wait(0.2)
                    continue
                if proc is None or rendered >= cfg.generate.recycle_every:
                    if proc is not None:
                        proc.close()
                    proc = WorkerProcess(log_path=logs / f"worker{w}.log", threads=threads)
                    live[w] = proc
                    ready = proc.start(worker_setup(cfg, layout))
                    if stop.is_set():  # stopped while it started
                        return
                    device[0] = ready.get("device", "")
                    camera_scale = float(ready.get("camera_scale", 1.0))
                    rendered = 0
                params = todo.draw(i)
                try:
                    reply = proc.render(params.to_dict())
                except WorkerCrashed as exc:
                    proc = None
                    if not stop.is_set():  # else we killed it ourselves (Ctrl-C)
                        retry_or_fail(i, f"worker crashed ({exc})")
                    continue
                if "error" in reply:
                    retry_or_fail(i, reply.get("message", "render error"))
                    continue
                finish_sample(layout, params, Rendered.from_dict(reply), camera_scale)
                rendered += views
                with lock:
                    remaining[0] -= 1
                bar.update(views)
        except WorkerCrashed as exc:  # crashed while starting: a setup problem, not a sample's
            stop.set()
            errors.append(disk_full(layout, str(exc), since=since) or f"worker failed to start: {exc}")
        except OSError as exc:  # the driver's own writes (sample records)
            stop.set()
            errors.append(disk_full(layout, str(exc)) if exc.errno in (errno.ENOSPC, errno.EDQUOT) else exc)
        except Exception as exc:  # pragma: no cover - surfaced to the caller below
            stop.set()
            errors.append(exc)
        finally:
            if proc is not None:
                proc.kill() if stop.is_set() else proc.close()

    pool = [threading.Thread(target=run_worker, args=(w,), daemon=True) for w in range(n_workers)]
    log.info("rendering with %d worker(s), %d Cycles thread(s) each", n_workers, threads)
    try:
        for t in pool:
            t.start()
        for t in pool:
            while t.is_alive():
                t.join(timeout=0.5)
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM raised as one
        stop.set()
        for proc in list(live.values()):
            proc.kill()
        for t in pool:
            t.join(timeout=10)
        for proc in list(live.values()):  # any started while the threads stopped
            proc.kill()
        bar.close()
        remove_partial_files(layout)
        raise
    bar.close()
    if errors:
        first = errors[0]
        if isinstance(first, UserError):
            raise first
        if isinstance(first, str):
            raise ResourceError(f"{first} (see {logs})")
        raise first
    if device[0]:
        log.info("Cycles device: %s", device[0])
    return retries.failed, device[0]
