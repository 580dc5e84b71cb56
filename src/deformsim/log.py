"""Logging and progress on stderr: rich lines and live bars on a terminal, plain unwrapped lines elsewhere.

Off a terminal (a log file, CI) a progress bar is a line at every 10 % of the work (at most one each
:data:`MIN_GAP_S`) and at least every :data:`EVERY_S` seconds, with the count, the rate and the time left; work done
within :data:`MIN_GAP_S` leaves no line. :func:`set_verbosity` picks which lines show.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from typing import Callable

from rich.console import Console
from rich.logging import RichHandler
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

MIN_GAP_S = 5.0  # off a terminal: the shortest time between two progress lines
EVERY_S = 30.0  # and the longest, while work goes on
LEVELS = {"quiet": logging.WARNING, "normal": logging.INFO, "verbose": logging.DEBUG}
TIME_FORMAT = "%Y-%m-%d %H:%M:%S"  # ISO 8601, on a terminal and off it
PLAIN = logging.Formatter("%(asctime)s %(levelname)s %(message)s", TIME_FORMAT)

_console = Console(stderr=True)
_root = logging.getLogger("deformsim")
_configured = False


class _Handler(logging.Handler):
    """Each record through rich when stderr is a terminal, else as one plain line on the current stderr."""

    def __init__(self):
        super().__init__()
        self._rich = RichHandler(console=_console, show_path=False, rich_tracebacks=False, markup=False,
                                 log_time_format=f"[{TIME_FORMAT}]", omit_repeated_times=False)

    def emit(self, record: logging.LogRecord) -> None:
        if _console.is_terminal:
            self._rich.emit(record)
            return
        try:
            sys.stderr.write(PLAIN.format(record) + "\n")
            sys.stderr.flush()
        except Exception:
            self.handleError(record)


def _configure() -> None:
    global _configured
    if not _configured:
        _root.addHandler(_Handler())
        _root.setLevel(logging.INFO)
        _root.propagate = False
        _configured = True


def get_logger(name: str) -> logging.Logger:
    _configure()
    return logging.getLogger(name)


def set_verbosity(level: str) -> None:
    """``quiet``: warnings and errors only (no progress); ``normal``: also progress and info; ``verbose``: debug."""
    if level not in LEVELS:
        raise ValueError(f"verbosity must be one of {', '.join(LEVELS)}, not {level!r}")
    _configure()
    _root.setLevel(LEVELS[level])


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}h{s % 3600 // 60:02d}m{s % 60:02d}s" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


class _Lines:
    """Progress as log lines (see the module's description); the last one when the work ends, if any was shown."""

    def __init__(self, total: int, desc: str, clock: Callable[[], float]):
        self.total, self.desc, self.clock = total, desc, clock
        self.done = self.shown = 0
        self.start = self.last = clock()
        self.step = max(1, -(-total // 10))
        self.log = get_logger("deformsim.progress")

    def advance(self, n: int) -> None:
        self.done += n
        now = self.clock()
        gap = now - self.last
        if gap >= EVERY_S or (gap >= MIN_GAP_S and self.done // self.step > self.shown // self.step):
            self._line(now)

    def _line(self, now: float) -> None:
        self.last, self.shown = now, self.done
        elapsed = now - self.start
        rate = self.done / elapsed if elapsed > 0 else 0.0
        speed = f"{rate:.2f}/s" if rate >= 1 or rate == 0 else f"{1 / rate:.1f} s each"
        pct = 100 * self.done // max(1, self.total)
        if self.done >= self.total:
            when = f"done in {_duration(elapsed)}"
        else:
            when = f"eta {_duration((self.total - self.done) / rate)}" if rate > 0 else "eta -"
        self.log.info("%s: %d/%d (%d%%), %s, %s", self.desc, self.done, self.total, pct, speed, when)

    def stop(self) -> None:
        if 0 < self.shown != self.done:
            self._line(self.clock())


class progress_bar:
    """A thread-safe progress bar: ``update(n)``, ``close()``; silent when disabled or at quiet verbosity.

    A live rich bar on a terminal; elsewhere progress lines in the log (``clock``: their time source).
    """

    def __init__(self, total: int, desc: str, enabled: bool = True, clock: Callable[[], float] = time.monotonic):
        self._lock = threading.Lock()
        self._progress = self._lines = None
        _configure()
        if not enabled or not _root.isEnabledFor(logging.INFO):
            return
        if _console.is_terminal:
            self._progress = Progress(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(), console=_console,
            )
            self._progress.start()
            self._task = self._progress.add_task(desc, total=total)
        else:
            self._lines = _Lines(total, desc, clock)

    def update(self, n: int = 1) -> None:
        with self._lock:
            if self._progress is not None:
                self._progress.advance(self._task, n)
            elif self._lines is not None:
                self._lines.advance(n)

    def close(self) -> None:
        with self._lock:
            if self._progress is not None:
                self._progress.stop()
            elif self._lines is not None:
                self._lines.stop()
            self._progress = self._lines = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
