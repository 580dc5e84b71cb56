"""What every render backend shares: the workers' setup, the worker count, retries and finished samples.

The backends (:mod:`deformsim.generate.local`, :mod:`deformsim.generate.ray`) hand samples to Blender
workers; the driver alone writes sample records, so resume, retries and the manifest work the same on both.
"""

from __future__ import annotations

import os
import shutil
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path

from deformsim.bank.store import bank_dir
from deformsim.config import Config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import read_record, rows_for, write_record
from deformsim.dataset.rendered import Rendered
from deformsim.errors import ResourceError
from deformsim.log import get_logger
from deformsim.parallel import worker_count
from deformsim.sampling import SampleParams
from deformsim.spec.model import load_spec

log = get_logger(__name__)


def render_workers(cfg: Config, samples: int) -> int:
    """Local render processes: ``generate.workers``, else 1 on a GPU, else one per 4 cores (at least one), each
    with its share of the cores as Cycles threads: on 2 cores one worker of 2 threads renders the same bytes as two of
    one, 1.22x as fast at 512 px and 1.1x at 128 px (``python bench/scale.py --config paper``)."""
    return worker_count(samples, cfg.generate.workers, cores_each=4,
                        most=1 if cfg.render.device == "gpu" else None)


def worker_setup(cfg: Config, layout: Layout, bank: Path | None = None) -> dict:
    """The setup message a Blender worker builds its scene from; ``bank``: a baked bank folder to load (by
    default the cached bank of ``cfg``'s spec and mesh when ``deform.sources`` uses it; bake it first)."""
    if bank is None and cfg.deform.sources.uses_bank:
        bank = bank_dir(load_spec(cfg.object.spec), cfg.object.mesh)
    return {
        "config": cfg.model_dump(mode="json"),
        "spec_path": str(cfg.object.spec) if cfg.object.spec else None,
        "out": str(layout.root),
        "bank": str(bank) if bank is not None else None,
    }


def finish_sample(layout: Layout, p: SampleParams, rendered: Rendered, camera_scale: float) -> None:
    """Record a rendered sample: its record is what marks it done for a resumed run."""
    write_record(layout, p, rows_for(p, layout, rendered, camera_scale))


def remove_partial_files(layout: Layout) -> None:
    """Temporary files of an interrupted run (never valid output) are removed before resuming."""
    for tmp in (layout.root / "images").glob("*/.*"):
        tmp.unlink(missing_ok=True)


DISK_FULL_TEXT = ("No space left on device", "Disk quota exceeded", "[Errno 28]", "[Errno 122]")
LOW_SPACE = 32 << 20  # bytes: a render that fails with less free space than this failed for want of space


def log_sizes(layout: Layout) -> dict[Path, int]:
    """Where each worker log ends now: what is written after belongs to this run."""
    return {p: p.stat().st_size for p in (layout.root / "logs").glob("*.log")}


def disk_full(layout: Layout, *reasons: str, since: dict[Path, int] | None = None) -> ResourceError | None:
    """The one-line error for a failure caused by a full disk, or None.

    The cause shows in the failure's reason, in what a worker logged after ``since`` (Blender prints it there,
    then fails to read its own truncated render), or as too little free space where the dataset is written.
    """
    logs = sorted((layout.root / "logs").glob("*.log")) if since is not None else []
    texts = list(reasons) + [_tail(p, (since or {}).get(p, 0)) for p in logs]
    try:
        free = shutil.disk_usage(layout.root).free
    except OSError:
        free = None
    if not any(s in t for t in texts for s in DISK_FULL_TEXT) and (free is None or free >= LOW_SPACE):
        return None
    left = f"; {free / 2**20:.0f} MB free" if free is not None else ""
    return ResourceError(f"the disk holding {layout.root} is full (No space left on device{left}): free some "
                         "space, then rerun the same command to resume")


def _tail(path: Path, start: int, size: int = 4096) -> str:
    """The last ``size`` bytes of ``path`` written after offset ``start``."""
    try:
        with open(path, "rb") as f:
            f.seek(max(start, f.seek(0, 2) - size))
            return f.read().decode(errors="replace")
    except OSError:
        return ""


class Retries:
    """Failed attempts per sample: each is retried up to ``max_retries`` times, then recorded in ``failed``."""

    def __init__(self, max_retries: int):
        self.max_retries = max_retries
        self.attempts: dict[int, int] = {}
        self.failed: dict[int, str] = {}  # sample -> reason of its last failure

    def retry(self, i: int, reason: str) -> bool:
        """Count a failed attempt of sample ``i``; True when it is to be tried again."""
        self.attempts[i] = self.attempts.get(i, 0) + 1
        if self.attempts[i] > self.max_retries:
            self.failed[i] = reason
            log.error("sample %d failed %d times, giving up: %s", i, self.attempts[i], reason)
            return False
        log.warning("sample %d: %s; retrying (%d/%d)", i, reason, self.attempts[i], self.max_retries)
        return True


def finished(layout: Layout, n: int) -> set[int]:
    """The samples below ``n`` with a complete record (:func:`~deformsim.dataset.manifest.read_record`): only the
    record files there are read, so a new run costs nothing whatever ``n``."""
    try:
        names = [e.name for e in os.scandir(layout.samples_dir)]
    except FileNotFoundError:
        return set()
    found = {int(name[:-5]) for name in names if name.endswith(".json") and name[:-5].isdigit()}
    return {i for i in found if i < n and read_record(layout, i) is not None}


class Todo:
    """The samples of ``range(n)`` still to render, handed out in order as workers ask (a retried one first): no
    list of them is made, and each sample's parameters are drawn by ``draw`` when it is handed out, so planning
    holds O(1) memory in ``n``. Thread-safe."""

    def __init__(self, n: int, done: set[int], draw: Callable[[int], SampleParams]):
        self.n, self.done, self.draw = n, done, draw
        self._next = 0
        self._again: deque[int] = deque()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        """The samples to render when the run started."""
        return self.n - len(self.done)

    def take(self) -> int | None:
        """The next sample to render, or None when every one has been handed out (retries may still come)."""
        with self._lock:
            if self._again:
                return self._again.popleft()
            while self._next < self.n and self._next in self.done:
                self._next += 1
            if self._next >= self.n:
                return None
            self._next += 1
            return self._next - 1

    def again(self, i: int) -> None:
        """Hand sample ``i`` out once more (a retry)."""
        with self._lock:
            self._again.append(i)
