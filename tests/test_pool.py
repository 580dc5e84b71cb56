"""The worker pool: each worker keeps its own state, every result reaches the caller, an error stops the run."""

from __future__ import annotations

import os
import time

import pytest

from deformsim.pool import Pool


class Counter:
    """A thread worker that records its jobs (job ``fail_on`` raises), and whether it was closed or killed."""

    def __init__(self, slot: int, fail_on: int | None = None):
        self.slot, self.fail_on, self.jobs, self.ended = slot, fail_on, [], None

    def __call__(self, job: int) -> tuple[int, int]:
        if job == self.fail_on:
            raise ValueError(f"job {job} failed")
        self.jobs.append(job)
        time.sleep(0.001)
        return self.slot, job

    def close(self) -> None:
        self.ended = "closed"

    def kill(self) -> None:
        self.ended = self.ended or "killed"


def test_thread_workers_keep_their_own_state_and_every_result_reaches_the_caller():
    made = {}

    def make(slot):
        made[slot] = Counter(slot)
        return made[slot]

    with Pool(make, 3) as pool:
        results = list(pool.map(range(30)))
    assert sorted(job for _, job in results) == list(range(30))
    assert sorted(made) == [0, 1, 2] and all(w.ended == "closed" for w in made.values())
    for slot, w in made.items():
        assert sorted(w.jobs) == sorted(job for s, job in results if s == slot)


def test_an_error_in_one_worker_is_raised_in_the_caller_and_the_others_end_killed():
    made = {}

    def make(slot):
        made[slot] = Counter(slot, fail_on=10)
        return made[slot]

    with pytest.raises(ValueError, match="job 10 failed"), Pool(make, 2) as pool:
        for _ in pool.map(range(10_000)):
            pass
    assert all(w.ended == "killed" for w in made.values())
    assert sum(len(w.jobs) for w in made.values()) < 1000  # the jobs left when it failed were dropped


class Square:
    def __init__(self, slot: int):
        self.slot = slot

    def __call__(self, job: int) -> tuple[int, int, int]:
        return self.slot, os.getpid(), job * job


@pytest.mark.parametrize("workers", [1, 2])
def test_processes_make_one_worker_each_and_one_worker_runs_in_the_caller(workers):
    with Pool(Square, workers, processes=True) as pool:
        results = list(pool.map(range(20), chunk=3))
    assert sorted(r[2] for r in results) == [j * j for j in range(20)]
    pids = {r[1] for r in results}
    assert {r[0] for r in results} <= set(range(workers))
    assert (pids == {os.getpid()}) == (workers == 1)
