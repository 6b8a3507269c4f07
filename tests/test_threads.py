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
    """The cheap jobs wait until both costly ones have started: with two threads that
    happens only if the costly two are taken first (else a thread blocks on a cheap
    job while a costly one waits behind it in the queue, and the wait times out)."""
    lock = threading.Lock()
    costly_started: list[int] = []
    both = threading.Event()

    def costly(i: int) -> tuple[int, bool]:
        with lock:
            costly_started.append(i)
            if len(costly_started) == 2:
                both.set()
        return i, True

    def cheap(i: int) -> tuple[int, bool]:
        return i, both.wait(timeout=5.0)

    kinds = [cheap, costly, cheap, costly, cheap]
    jobs = [lambda i=i, kind=kind: kind(i) for i, kind in enumerate(kinds)]
    results = run_on_threads(jobs, 2, costs=[1.0, 5.0, 2.0, 9.0, 0.5])
    assert results == [(i, True) for i in range(5)]
    assert sorted(costly_started) == [1, 3]
