"""``impeller_cam.threads``: the thread count and the pool of independent jobs."""

from __future__ import annotations

import threading

import pytest

from impeller_cam.threads import default_threads, run_on_threads


def test_results_come_back_in_the_order_of_the_jobs_on_any_thread_count() -> None:
    jobs = [lambda i=i: i * i for i in range(7)]
    for threads in (1, 2, 5, 16):
        assert run_on_threads(jobs, threads) == [i * i for i in range(7)]
    assert run_on_threads([], 4) == []


def test_one_thread_runs_the_jobs_in_the_callers_thread() -> None:
    names = run_on_threads([lambda: threading.current_thread().name] * 3, 1)
    assert names == [threading.current_thread().name] * 3


def test_a_jobs_exception_reaches_the_caller() -> None:
    def bad() -> int:
        raise ValueError("job failed")

    with pytest.raises(ValueError, match="job failed"):
        run_on_threads([lambda: 1, bad, lambda: 3], 2)


def test_the_thread_count_follows_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("IMPELLER_CAM_THREADS", "3")
    assert default_threads() == 3
    monkeypatch.setenv("IMPELLER_CAM_THREADS", "zero")
    assert default_threads() >= 1


def test_the_costliest_jobs_start_first_and_the_results_keep_the_jobs_order() -> None:
    started: list[int] = []
    jobs = [lambda i=i: started.append(i) or i for i in range(5)]
    assert run_on_threads(jobs, 2, costs=[1.0, 5.0, 2.0, 9.0, 0.5]) == [0, 1, 2, 3, 4]
    assert sorted(started) == [0, 1, 2, 3, 4]
    # the two costliest are taken from the queue first, so one of them starts first
    # (which of the two is up to the threads)
    assert started[0] in (3, 1)
