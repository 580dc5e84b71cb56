"""A worker pool: ``n`` workers, each an object that holds its own state, run jobs in threads or processes.

The results come back to the caller's thread as they finish, so the caller keeps every count without locks. A
worker's error stops the pool and is raised in the caller. Leaving the pool's ``with`` block stops it: on an error
the jobs under way end first; on Ctrl-C (or SIGTERM raised as KeyboardInterrupt) every thread worker is killed at
once (its ``kill``); jobs not started are dropped.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import threading
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable, Generic, Iterable, Iterator, Protocol, TypeVar

from deformsim.parallel import die_with_parent

J = TypeVar("J")
R = TypeVar("R")
J_contra = TypeVar("J_contra", contravariant=True)
R_co = TypeVar("R_co", covariant=True)


class Worker(Protocol[J_contra, R_co]):
    """One worker's state and its job: ``worker(job)`` returns the job's result."""

    def __call__(self, job: J_contra) -> R_co: ...


class Stopped(Exception):
    """Raised by a thread worker that saw the pool stop (:attr:`Pool.stopping`) while on a job: the job is dropped."""


class Pool(Generic[J, R]):
    """``workers`` workers, each ``make(slot)`` (slot 0 to workers - 1) made in the thread or process it runs in;
    used as ``with Pool(...) as pool: for result in pool.map(jobs): ...``.

    ``processes``: worker processes (``make`` and the jobs pickled; ``setup`` runs first in each, and the process
    ends with its parent; one worker runs in the caller), else threads. A thread worker may have ``close()``, called
    when it is done, and ``kill()``, called instead when the pool stops early.
    """

    def __init__(self, make: Callable[[int], Worker[J, R]], workers: int, processes: bool = False,
                 setup: Callable[[], None] | None = None):
        self.make, self.workers, self.processes, self.setup = make, workers, processes, setup
        self.stopping = threading.Event()  # set when the pool stops early: an error or Ctrl-C
        self._made: list = []
        self._threads: list[threading.Thread] = []
        self._executor: ProcessPoolExecutor | None = None

    def __enter__(self) -> Pool[J, R]:
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if self._executor is not None:
            self._executor.shutdown(cancel_futures=True)
        if kind is not None and issubclass(kind, KeyboardInterrupt):
            self._kill()
        elif any(t.is_alive() for t in self._threads):  # an error, or the caller stopped early
            self.stopping.set()
            try:
                for t in self._threads:
                    while t.is_alive():
                        t.join(timeout=0.5)  # a timeout, so that Ctrl-C is seen at once
            except KeyboardInterrupt:
                self._kill()
                raise

    def map(self, jobs: Iterable[J], chunk: int = 1) -> Iterator[R]:
        """The results of ``jobs``, as they finish (processes take ``chunk`` jobs at a time); thread workers take
        the next job from ``jobs`` as they are free, so it may be a generator that waits for more."""
        if self.workers == 1 and self.processes:
            worker = self.make(0)
            return (worker(job) for job in jobs)
        return self._processes(list(jobs), chunk) if self.processes else self._run_threads(iter(jobs))

    def _processes(self, jobs: list[J], chunk: int) -> Iterator[R]:
        slots = multiprocessing.get_context().Value("i", 0)
        self._executor = ProcessPoolExecutor(self.workers, initializer=_start,
                                             initargs=(self.make, self.setup, slots, os.getpid()))
        futures = [self._executor.submit(_run_chunk, jobs[i : i + chunk]) for i in range(0, len(jobs), chunk)]
        for future in as_completed(futures):
            yield from future.result()

    def _run_threads(self, jobs: Iterator[J]) -> Iterator[R]:
        self._made = [self.make(slot) for slot in range(self.workers)]
        done: queue.Queue = queue.Queue()
        lock = threading.Lock()

        def run(worker: Worker[J, R]) -> None:
            try:
                while not self.stopping.is_set():
                    with lock:
                        job = next(jobs, _END)
                    if job is _END:
                        break
                    done.put((worker(job), None))
            except Stopped:
                pass
            except BaseException as exc:  # raised in the caller
                self.stopping.set()
                done.put((None, exc))
            finally:
                end = getattr(worker, "kill" if self.stopping.is_set() else "close", None)
                if end is not None:
                    end()
                done.put((_END, None))

        self._threads = [threading.Thread(target=run, args=(w,), daemon=True) for w in self._made]
        for t in self._threads:
            t.start()
        running = len(self._threads)
        while running:
            try:
                result, error = done.get(timeout=0.5)  # a timeout, so that Ctrl-C is seen at once
            except queue.Empty:
                continue
            if error is not None:
                raise error
            if result is _END:
                running -= 1
            else:
                yield result

    def _kill(self) -> None:
        """Stop now: kill every worker, give the threads 10 s to end, kill again any worker started meanwhile."""
        self.stopping.set()
        _kill_all(self._made)
        for t in self._threads:
            t.join(timeout=10)
        _kill_all(self._made)


def _kill_all(made: list) -> None:
    for worker in made:
        kill = getattr(worker, "kill", None)
        if kill is not None:
            kill()


_END = object()
_WORKER: Worker | None = None  # this worker process's worker


def _start(make: Callable[[int], Worker], setup: Callable[[], None] | None, slots, parent: int) -> None:
    global _WORKER
    die_with_parent(parent)
    if setup is not None:
        setup()
    with slots.get_lock():
        slot, slots.value = slots.value, slots.value + 1
    _WORKER = make(slot)


def _run_chunk(jobs: list) -> list:
    return [_WORKER(job) for job in jobs]
