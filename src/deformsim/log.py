"""Logging and progress bars for long work (rich on a terminal, plain lines otherwise)."""

from __future__ import annotations

import logging
import threading

from rich.logging import RichHandler
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

_configured = False


def get_logger(name: str) -> logging.Logger:
    global _configured
    if not _configured:
        handler = RichHandler(show_path=False, rich_tracebacks=False, markup=False)
        root = logging.getLogger("deformsim")
        root.addHandler(handler)
        root.setLevel(logging.INFO)
        root.propagate = False
        _configured = True
    return logging.getLogger(name)


class progress_bar:
    """A thread-safe progress bar: ``update(n)``, ``close()``; silent when disabled."""

    def __init__(self, total: int, desc: str, enabled: bool = True):
        self._lock = threading.Lock()
        self._progress = None
        if enabled:
            self._progress = Progress(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
            )
            self._progress.start()
            self._task = self._progress.add_task(desc, total=total)

    def update(self, n: int = 1) -> None:
        if self._progress is not None:
            with self._lock:
                self._progress.advance(self._task, n)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
