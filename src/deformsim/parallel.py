"""Worker processes: how many a stage runs (one rule for render workers, Ray actors and composite processes), workers
that end with their parent, and folders named after the process working in them."""

from __future__ import annotations

import math
import os
import signal
import socket
import sys
import threading
import time
from pathlib import Path

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


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


def die_with_parent(parent: int) -> None:
    """Make this worker process end when its parent ``parent`` does, even by kill -9 (Linux: the kernel's
    parent-death signal; elsewhere a thread that watches the parent); it ends at once when the parent is gone."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    else:
        threading.Thread(target=_watch, args=(parent,), daemon=True).start()
    if os.getppid() != parent:
        os._exit(1)


def _watch(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(1)
    os._exit(1)


def owner_tag() -> str:
    """This process as ``HOST-PID-START`` (START: when it started, so a reused pid differs), for the names of
    folders it alone works in; :func:`owner_gone` tells when such a folder is left over."""
    return f"{socket.gethostname()}-{os.getpid()}-{_started(os.getpid())}"


def owner_gone(tag: str) -> bool:
    """Whether the process that :func:`owner_tag` named ``tag`` on this host has ended (False when unsure:
    another host's, or not such a tag)."""
    host, pid, start = (tag.rsplit("-", 2) + ["", ""])[:3]
    if host != socket.gethostname() or not pid.isdigit():
        return False
    return _started(int(pid)) != start


def _started(pid: int) -> str | None:
    """When process ``pid`` started (clock ticks after boot; "0" without /proc), None when it has ended."""
    proc = Path("/proc")
    if not proc.is_dir():
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return None
        except PermissionError:  # another user's process
            pass
        return "0"
    try:
        fields = (proc / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return None if fields[0] == "Z" else fields[19]
