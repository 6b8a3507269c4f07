"""``impeller_cam.processes.map_forked``: jobs on forked processes, the results of the
plain calls in the jobs' order."""

from __future__ import annotations

import os

import pytest

from impeller_cam.processes import map_forked


def test_results_come_back_in_the_jobs_order_from_other_processes() -> None:
    for workers in (1, 2, 4):
        assert map_forked(lambda i: i * i, 7, workers) == [i * i for i in range(7)]
    assert map_forked(lambda i: i, 0, 2) == []
    pids = set(map_forked(lambda i: os.getpid(), 6, 2))
    assert os.getpid() not in pids and len(pids) >= 1
    assert map_forked(lambda i: os.getpid(), 3, 1) == [os.getpid()] * 3


def test_done_sees_every_job_once_and_the_costliest_start_first() -> None:
    seen: list[tuple[int, int]] = []
    assert map_forked(lambda i: -i, 5, 1, costs=[1, 5, 2, 4, 3],
                      done=lambda i, r: seen.append((i, r))) == [0, -1, -2, -3, -4]
    assert seen == [(1, -1), (3, -3), (4, -4), (2, -2), (0, 0)]  # one worker: by cost
    seen.clear()
    map_forked(lambda i: -i, 5, 2, done=lambda i, r: seen.append((i, r)))
    assert sorted(seen) == [(i, -i) for i in range(5)]


def test_a_failing_job_raises_its_own_exception_in_the_caller() -> None:
    ran: list[int] = []

    def job(i: int) -> int:
        ran.append(os.getpid())
        if i == 3:
            raise ValueError(f"job {i} failed")
        return i

    with pytest.raises(ValueError, match="job 3 failed"):
        map_forked(job, 5, 2)
    assert ran == [os.getpid()]  # only the failed job ran again here


def test_a_result_that_does_not_pickle_is_made_in_the_caller() -> None:
    made = map_forked(lambda i: (lambda: (i, os.getpid())), 3, 2)
    assert [f() for f in made] == [(i, os.getpid()) for i in range(3)]


def test_a_child_maps_its_own_jobs_itself() -> None:
    def job(i: int) -> list[int]:
        outer = os.getpid()
        inner = map_forked(lambda j: os.getpid(), 3, 2)
        return [int(p == outer) for p in inner]

    assert map_forked(job, 2, 2) == [[1, 1, 1], [1, 1, 1]]


class _Counter:
    """Counts calls and keeps answers, with the fork protocol of ``map_forked``."""

    def __init__(self) -> None:
        self.calls = 0
        self.kept: dict[int, int] = {}

    def ask(self, i: int) -> int:
        self.calls += 1
        return self.kept.setdefault(i, i * i)

    def fork_mark(self) -> tuple[int, int]:
        return self.calls, len(self.kept)

    def fork_delta(self, mark: tuple[int, int]) -> tuple[int, dict[int, int]]:
        return self.calls - mark[0], dict(list(self.kept.items())[mark[1]:])

    def merge_fork_delta(self, delta: tuple[int, dict[int, int]]) -> None:
        self.calls += delta[0]
        self.kept.update(delta[1])


def test_what_the_jobs_change_in_keep_ends_in_the_callers_object() -> None:
    for workers in (1, 2):
        counter = _Counter()
        assert map_forked(lambda i, c=counter: c.ask(i) + c.ask(i), 6, workers,
                          keep=counter) == [2 * i * i for i in range(6)]
        assert counter.calls == 12
        assert counter.kept == {i: i * i for i in range(6)}
    assert map_forked(lambda i: i, 3, 2, keep=object()) == [0, 1, 2]  # no protocol: ignored
