"""How many worker processes a stage runs: one rule for render workers, Ray actors and composite processes."""

from __future__ import annotations

import math
import os


def worker_count(jobs: int, requested: int = 0, *, cores: int | None = None, cores_each: int = 1, least: int = 1,
                 most: int | None = None, jobs_each: int = 1) -> int:
    """Workers for ``jobs`` jobs: ``requested`` when set, else one per ``cores_each`` cores, at least ``least``
    (but never more than the cores), at most ``most`` and ``ceil(jobs / jobs_each)``; always 1 to ``jobs``.

    ``cores`` defaults to this machine's CPU count.
    """
    if requested:
        return max(1, min(requested, jobs))
    cores = (os.cpu_count() or 1) if cores is None else cores
    n = min(cores, max(least, cores // cores_each), math.ceil(jobs / jobs_each))
    if most is not None:
        n = min(n, most)
    return max(1, min(n, jobs))


def cores_per_worker(workers: int, cores: int | None = None) -> int:
    """An even share of ``cores`` (default: this machine's) for each of ``workers`` workers, at least 1."""
    cores = (os.cpu_count() or 1) if cores is None else cores
    return max(1, cores // workers)
