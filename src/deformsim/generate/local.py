"""Render on this machine: a pool of threads, each driving one Blender worker process.

Ctrl-C and SIGTERM (raised as KeyboardInterrupt by the command line) kill every worker at once and remove the
partial files; a full disk stops the whole run with one line instead of failing every sample.
"""

from __future__ import annotations

import errno
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from deformsim.config import Config
from deformsim.dataset.layout import Layout
from deformsim.dataset.rendered import Rendered
from deformsim.errors import ResourceError
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
from deformsim.pool import Pool, Stopped

log = get_logger(__name__)


def run_local(cfg: Config, layout: Layout, todo: Todo, progress: bool) -> tuple[dict[int, str], str]:
    """Render the samples of ``todo`` with local worker processes; returns (failed samples with reasons, device)."""
    n_workers = render_workers(cfg, len(todo))
    threads = cfg.render.threads or cores_per_worker(n_workers)
    views = len(cfg.camera.azimuth_quadrants)
    retries = Retries(cfg.generate.max_retries)
    logs = layout.root / "logs"
    logs.mkdir(exist_ok=True)
    since = log_sizes(layout)
    left = _Left(len(todo))
    device = ""
    log.info("rendering with %d worker(s), %d Cycles thread(s) each", n_workers, threads)
    try:
        with progress_bar(total=len(todo) * views, desc="render", enabled=progress) as bar, \
                Pool(lambda slot: Renderer(slot, cfg, layout, todo, threads, pool.stopping), n_workers) as pool:
            for out in pool.map(_pending(todo, left, pool.stopping)):
                device = out.device or device
                if out.failed is None:
                    left.samples -= 1
                    bar.update(views)
                    continue
                full = disk_full(layout, out.failed, since=since)
                if full is not None:  # every other sample would fail the same way
                    raise full
                if retries.retry(out.sample, out.failed):
                    todo.again(out.sample)
                else:
                    left.samples -= 1
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM raised as one: the pool killed the workers
        remove_partial_files(layout)
        raise
    except WorkerCrashed as exc:  # crashed while starting: a setup problem, not a sample's
        full = disk_full(layout, str(exc), since=since)
        raise full or ResourceError(f"worker failed to start: {exc} (see {logs})") from None
    except OSError as exc:  # the driver's own writes (sample records)
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise (disk_full(layout, str(exc)) or exc) from None
        raise
    if device:
        log.info("Cycles device: %s", device)
    return retries.failed, device


@dataclass
class _Left:
    samples: int  # not yet rendered nor given up


@dataclass(frozen=True)
class Outcome:
    """A sample rendered (``failed`` None) or failed (why), and the Cycles device of the worker that tried it."""

    sample: int
    failed: str | None
    device: str


def _pending(todo: Todo, left: _Left, stopping: threading.Event) -> Iterator[int]:
    """The samples to render as workers ask, until none is left (a retried one may still come while some are out)
    or the run stops."""
    while left.samples > 0 and not stopping.is_set():
        i = todo.take()
        if i is None:  # every sample handed out; a retry may still come
            stopping.wait(0.2)
            continue
        yield i


class Renderer:
    """One render worker: drives a Blender worker process (started when needed, restarted every
    ``generate.recycle_every`` views) and renders one sample at a time."""

    def __init__(self, slot: int, cfg: Config, layout: Layout, todo: Todo, threads: int, stopping: threading.Event):
        self.cfg, self.layout, self.todo, self.threads, self.stopping = cfg, layout, todo, threads, stopping
        self.log_path: Path = layout.root / "logs" / f"worker{slot}.log"
        self.proc: WorkerProcess | None = None
        self.rendered, self.camera_scale, self.device = 0, 1.0, ""

    def __call__(self, i: int) -> Outcome:
        if self.proc is None or self.rendered >= self.cfg.generate.recycle_every:
            if self.proc is not None:
                self.proc.close()
            self.proc = WorkerProcess(log_path=self.log_path, threads=self.threads)
            ready = self.proc.start(worker_setup(self.cfg, self.layout))
            if self.stopping.is_set():  # stopped while it started
                raise Stopped
            self.device = ready.get("device", "")
            self.camera_scale = float(ready.get("camera_scale", 1.0))
            self.rendered = 0
        params = self.todo.draw(i)
        try:
            reply = self.proc.render(params.to_dict())
        except WorkerCrashed as exc:
            self.proc = None
            if self.stopping.is_set():  # we killed it ourselves (Ctrl-C)
                raise Stopped from None
            return Outcome(i, f"worker crashed ({exc})", self.device)
        if "error" in reply:
            return Outcome(i, reply.get("message", "render error"), self.device)
        finish_sample(self.layout, params, Rendered.from_dict(reply), self.camera_scale)
        self.rendered += len(self.cfg.camera.azimuth_quadrants)
        return Outcome(i, None, self.device)

    def close(self) -> None:
        if self.proc is not None:
            self.proc.close()

    def kill(self) -> None:
        if self.proc is not None:
            self.proc.kill()
