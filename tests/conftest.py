"""Test-suite wide notes: how the tests share the two workers, and the tiers.

``scripts/test`` runs ``pytest -n 2 --dist loadscope --no-loadscope-reorder``: the
tests of one module run on one worker, so a module-scoped fixture (nine_blade's
roughing run) is built once. The small fixture's whole chain (``chain_small``,
tests/cam/conftest.py), used by several modules, is built once for both workers, in
the base folder they share, under a lock. (pytest-xdist's ``xdist_group`` marks did
not group anything with pytest 9: the worker's node ids no longer take its group
suffix.)

The workers take the modules in the order ``pytest_collection_modifyitems`` leaves
them (``--no-loadscope-reorder``; xdist's own order, most tests first, put the long
modules of one or two tests last, where one worker ran them alone): the first module
that uses ``chain_small`` (it builds the chain while the other worker runs other
modules), then the modules with a ``slow`` test (the long ones), then the others; in
both groups the other ``chain_small`` users come last (the chain is built by then, so
no worker waits for it); collection order otherwise. Many short modules at the end
keep both workers busy to the end.

Tiers: ``-m "not slow"`` is the fast tier (unit, property and the small fixture's
chain); ``slow`` marks the acceptance runs on the nine_blade and splitter fixtures,
LinuxCNC's impeller demo and other tests that take more than about 15 s of a core.
``acceptance`` marks whole main-job-size chains (tens of minutes each): they run only
with ``pytest --acceptance``. The terminal summary shows the seconds each tier took
(``tier_seconds``: setup, call and teardown summed over the tests of the tier, on
whichever worker ran them), so that a test growing out of its tier is seen, and
the CPU seconds they took (``tier_cpu_seconds``: the worker process's and the
subprocesses it waited for; on a shared, loaded machine the wall seconds grow with
the load, the CPU seconds hardly: compare those between runs on a busy machine).
Then the modules that took the most CPU seconds (``module_seconds``: under loadscope
the longest module bounds the wall time from below) and, under xdist, when each
worker finished and its CPU seconds (``worker_seconds``: the idle tail of the worker
that finished first is what the schedule loses).

Each xdist worker is one of the machine's CPUs: it runs with ``IMPELLER_CAM_THREADS=1``
(unless that is set), so the product's threads (the sweep, grid builds) and forked
processes (the finishing planner, ``impeller_cam.processes``) do not oversubscribe
the cores the other worker is using (the fast tier ran 182.6 s with them, 175.4 s
without, on 2 cores). The tests of those parallel paths ask for their threads or
processes explicitly and compare them with one.
"""

from __future__ import annotations

import os
import resource
import time
from collections.abc import Generator, Iterable
from typing import Any

import pytest

#: ``user_properties`` key of a report's CPU seconds (``cpu_seconds``).
CPU_KEY = "cpu_s"
_CPU_START = pytest.StashKey[float]()
_CPU_SPENT = pytest.StashKey[float]()
#: Modules listed in the terminal summary, the most CPU seconds first.
MODULES_SHOWN = 12


def pytest_configure(config: pytest.Config) -> None:
    if os.environ.get("PYTEST_XDIST_WORKER"):  # one worker, one CPU (module docstring)
        os.environ.setdefault("IMPELLER_CAM_THREADS", "1")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--acceptance", action="store_true", default=False,
                     help="also run the whole-chain acceptance runs (marker 'acceptance')")


@pytest.hookimpl(trylast=True)  # after ``-m``/``-k`` deselected their items
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if not config.getoption("--acceptance"):
        skip = pytest.mark.skip(reason="whole-chain acceptance run: pytest --acceptance")
        for item in items:
            if "acceptance" in item.keywords:
                item.add_marker(skip)
    items[:] = in_module_order(items)


def in_module_order(items: list[pytest.Item]) -> list[pytest.Item]:
    """The items grouped by module, the modules in the order the workers should take
    them (module docstring): the first ``chain_small`` user, the modules with a ``slow``
    test, the others, in both groups the other ``chain_small`` users last; collection
    order within each group and within each module."""
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(item.nodeid.split("::", 1)[0], []).append(item)

    def uses_chain(module: list[pytest.Item]) -> bool:
        return any("chain_small" in getattr(item, "fixturenames", ()) for item in module)

    builder = next((name for name, module in modules.items() if uses_chain(module)), None)

    def group(name: str) -> tuple[int, bool]:
        module = modules[name]
        if name == builder:
            return 0, False
        slow = any(item.get_closest_marker("slow") is not None
                   and item.get_closest_marker("skip") is None for item in module)
        return (1 if slow else 2), uses_chain(module)

    order = sorted(modules, key=group)  # stable: collection order within a group
    return [item for name in order for item in modules[name]]


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process's threads and of the subprocesses
    it has waited for."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item: pytest.Item) -> Generator[None, None, None]:
    yield from _cpu_of_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Generator[None, None, None]:
    yield from _cpu_of_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item: pytest.Item) -> Generator[None, None, None]:
    yield from _cpu_of_phase(item)


def _cpu_of_phase(item: pytest.Item) -> Generator[None, None, None]:
    item.stash[_CPU_START] = cpu_seconds()
    yield
    item.stash[_CPU_SPENT] = cpu_seconds() - item.stash[_CPU_START]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]
                              ) -> Generator[None, Any, None]:
    outcome = yield
    spent = item.stash.get(_CPU_SPENT, None)
    if spent is not None:  # the phase's CPU seconds travel with its report to the controller
        outcome.get_result().user_properties.append((CPU_KEY, spent))
        del item.stash[_CPU_SPENT]


def _phases(reports: Iterable[Any]) -> Iterable[Any]:
    """The test reports of a setup, call or teardown phase (not collect reports)."""
    return (report for report in reports
            if getattr(report, "when", None) in ("setup", "call", "teardown"))


def _cpu(report: Any) -> float:
    """A phase report's CPU seconds (``CPU_KEY`` of its ``user_properties``), or 0."""
    return sum(float(value) for key, value in getattr(report, "user_properties", ())
               if key == CPU_KEY)


def tier_seconds(reports: Iterable[Any]) -> dict[str, tuple[int, float]]:
    """Per tier (``"fast"``, ``"slow"``): the number of tests and the seconds their
    setup, call and teardown took, summed (the workers' seconds, not wall time).

    Parameters
    ----------
    reports : iterable
        Test reports (``pytest.TestReport``: ``nodeid``, ``when``, ``duration`` in s,
        ``keywords``); other objects (collect reports, warnings) are left out.
    """
    tests: dict[str, set[str]] = {"fast": set(), "slow": set()}
    seconds = {"fast": 0.0, "slow": 0.0}
    for report in _phases(reports):
        tier = "slow" if "slow" in report.keywords else "fast"
        tests[tier].add(report.nodeid)
        seconds[tier] += float(report.duration)
    return {tier: (len(tests[tier]), seconds[tier]) for tier in tests}


def tier_cpu_seconds(reports: Iterable[Any]) -> dict[str, float]:
    """Per tier (``"fast"``, ``"slow"``): the CPU seconds of the tests' setup, call and
    teardown, summed (``CPU_KEY`` of the reports' ``user_properties``; reports without
    it count nothing).

    Parameters
    ----------
    reports : iterable
        As for ``tier_seconds``; ``user_properties``: list of (name, value) pairs.
    """
    seconds = {"fast": 0.0, "slow": 0.0}
    for report in _phases(reports):
        seconds["slow" if "slow" in report.keywords else "fast"] += _cpu(report)
    return seconds


def module_seconds(reports: Iterable[Any]) -> list[tuple[str, int, float, float]]:
    """Per test module: its path, number of tests, seconds and CPU seconds (setup,
    call and teardown summed), the most CPU first. Under ``--dist loadscope`` a
    module runs on one worker: the longest module bounds the run's wall time from
    below, and the list shows where the tiers' seconds go.

    Parameters
    ----------
    reports : iterable
        As for ``tier_seconds`` (``nodeid`` ``path::name``).
    """
    tests: dict[str, set[str]] = {}
    seconds: dict[str, list[float]] = {}
    for report in _phases(reports):
        module = report.nodeid.split("::", 1)[0]
        tests.setdefault(module, set()).add(report.nodeid)
        spent = seconds.setdefault(module, [0.0, 0.0])
        spent[0] += float(report.duration)
        spent[1] += _cpu(report)
    return sorted(((module, len(tests[module]), wall, cpu)
                   for module, (wall, cpu) in seconds.items()), key=lambda row: -row[3])


def worker_seconds(reports: Iterable[Any]) -> dict[str, tuple[float, float, float]]:
    """Per worker (pytest-xdist's gateway id, ``"master"`` without xdist): the wall
    clock of its first phase's start and its last phase's end (s since the epoch) and
    its CPU seconds summed. The workers' ends differ by the idle tail of the one that
    finished first: the schedule's loss on two cores.

    Parameters
    ----------
    reports : iterable
        As for ``tier_seconds``, with ``start`` and ``stop`` (s since the epoch) and,
        under xdist, ``node.gateway.id``.
    """
    spans: dict[str, list[float]] = {}
    for report in _phases(reports):
        gateway = getattr(getattr(report, "node", None), "gateway", None)
        worker = str(getattr(gateway, "id", "master"))
        start, stop = float(getattr(report, "start", 0.0)), float(getattr(report, "stop", 0.0))
        span = spans.setdefault(worker, [start, stop, 0.0])
        span[0], span[1] = min(span[0], start), max(span[1], stop)
        span[2] += _cpu(report)
    return {worker: (first, last, cpu) for worker, (first, last, cpu) in sorted(spans.items())}


def pytest_terminal_summary(terminalreporter: Any) -> None:
    reports = [report for replist in terminalreporter.stats.values() for report in replist]
    tiers = tier_seconds(reports)
    if not any(count for count, _ in tiers.values()):
        return
    cpu = tier_cpu_seconds(reports)
    terminalreporter.write_sep("=", "seconds per tier (summed over the workers)")
    for tier, (count, seconds) in tiers.items():
        terminalreporter.write_line(f"{tier}: {count} tests, {seconds:.1f} s "
                                    f"(CPU {cpu[tier]:.1f} s)")
    modules = module_seconds(reports)
    terminalreporter.write_sep("-", "seconds per module (the most CPU first, "
                                    f"{min(len(modules), MODULES_SHOWN)} of {len(modules)})")
    for module, count, seconds, spent in modules[:MODULES_SHOWN]:
        terminalreporter.write_line(f"{module}: {count} tests, {seconds:.1f} s "
                                    f"(CPU {spent:.1f} s)")
    workers = worker_seconds(reports)
    if len(workers) > 1:
        start = min(first for first, _, _ in workers.values())
        end = max(last for _, last, _ in workers.values())
        terminalreporter.write_line("workers: " + ", ".join(
            f"{worker} done at {last - start:.0f} s (CPU {spent:.1f} s)"
            for worker, (_, last, spent) in workers.items())
            + f"; idle tail {end - min(last for _, last, _ in workers.values()):.0f} s")
