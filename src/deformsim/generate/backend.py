"""What every render backend shares: the workers' setup, the worker count, retries and finished samples.

The backends (:mod:`deformsim.generate.local`, :mod:`deformsim.generate.ray`) hand samples to Blender
workers; the driver alone writes sample records, so resume, retries and the manifest work the same on both.
"""

from __future__ import annotations

from deformsim.config import Config
from deformsim.dataset.layout import RENDER_KINDS, Layout
from deformsim.dataset.manifest import rows_for, write_record
from deformsim.log import get_logger
from deformsim.parallel import worker_count
from deformsim.sampling import SampleParams

log = get_logger(__name__)


def render_workers(cfg: Config, samples: int) -> int:
    """Local render processes: ``generate.workers``, else 1 on a GPU, else 2 (1 on one core) up to a quarter
    of the cores; two processes hide each other's per-render fixed costs (bench/scale.py: 1.23x on 2 cores)."""
    return worker_count(samples, cfg.generate.workers, cores_each=4, least=2,
                        most=1 if cfg.render.device == "gpu" else None)


def worker_setup(cfg: Config, layout: Layout) -> dict:
    """The setup message a Blender worker builds its scene from."""
    return {
        "config": cfg.model_dump(mode="json"),
        "spec_path": str(cfg.object.spec) if cfg.object.spec else None,
        "out": str(layout.root),
    }


def finish_sample(layout: Layout, p: SampleParams, render_seconds: list[float], camera_scale: float) -> None:
    """Record a rendered sample: its record is what marks it done for a resumed run."""
    write_record(layout, p, rows_for(p, layout, render_seconds, camera_scale))


def remove_partial_files(layout: Layout) -> None:
    """Temporary files of an interrupted run (never valid output) are removed before resuming."""
    for kind in RENDER_KINDS:
        for tmp in (layout.root / "images" / kind).glob(".*"):
            tmp.unlink(missing_ok=True)


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
