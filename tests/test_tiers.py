"""The seconds of the terminal summary (tests/conftest.py): per tier (``tier_seconds``,
``tier_cpu_seconds``), per module (``module_seconds``) and per worker
(``worker_seconds``)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from xml.etree import ElementTree

import pytest

from tests.conftest import (
    CPU_KEY,
    cpu_seconds,
    module_seconds,
    tier_cpu_seconds,
    tier_seconds,
    worker_seconds,
)

ROOT = Path(__file__).resolve().parents[1]


def report(nodeid: str, when: str, duration: float, slow: bool, cpu: float | None = None
           ) -> SimpleNamespace:
    keywords = {"slow": 1} if slow else {}
    properties = [] if cpu is None else [("other", 9.0), (CPU_KEY, cpu)]
    return SimpleNamespace(nodeid=nodeid, when=when, duration=duration, keywords=keywords,
                           user_properties=properties)


def test_setup_call_and_teardown_summed_per_tier() -> None:
    reports = [report("a", "setup", 60.0, False), report("a", "call", 0.5, False),
               report("a", "teardown", 0.25, False), report("b", "call", 1.0, False),
               report("c", "setup", 2.0, True), report("c", "call", 30.0, True),
               SimpleNamespace(nodeid="tests/x.py"),  # a collect report: no ``when``
               "a warning"]
    tiers = tier_seconds(reports)
    assert tiers["fast"] == (2, pytest.approx(61.75))
    assert tiers["slow"] == (1, pytest.approx(32.0))


def test_no_reports_no_tests() -> None:
    assert tier_seconds([]) == {"fast": (0, 0.0), "slow": (0, 0.0)}


def test_cpu_seconds_summed_per_tier() -> None:
    reports = [report("a", "setup", 60.0, False, cpu=20.0), report("a", "call", 0.5, False),
               report("b", "call", 1.0, False, cpu=0.75), report("c", "call", 30.0, True,
                                                                  cpu=12.5),
               SimpleNamespace(nodeid="tests/x.py"), "a warning"]
    assert tier_cpu_seconds(reports) == {"fast": pytest.approx(20.75),
                                         "slow": pytest.approx(12.5)}
    assert tier_cpu_seconds([]) == {"fast": 0.0, "slow": 0.0}


def test_modules_summed_and_the_most_cpu_first() -> None:
    reports = [report("tests/a.py::x", "setup", 5.0, False, cpu=4.0),
               report("tests/a.py::x", "call", 1.0, False, cpu=1.0),
               report("tests/a.py::y[1]", "call", 2.0, True, cpu=1.5),
               report("tests/b.py::z", "call", 3.0, False, cpu=9.0),
               report("tests/c.py::w", "call", 0.5, False),  # no CPU recorded: 0
               SimpleNamespace(nodeid="tests/d.py"), "a warning"]
    assert module_seconds(reports) == [
        ("tests/b.py", 1, pytest.approx(3.0), pytest.approx(9.0)),
        ("tests/a.py", 2, pytest.approx(8.0), pytest.approx(6.5)),
        ("tests/c.py", 1, pytest.approx(0.5), 0.0)]
    assert module_seconds([]) == []


def test_workers_span_from_first_start_to_last_stop() -> None:
    def on(worker: str | None, start: float, stop: float, cpu: float) -> SimpleNamespace:
        phase = report("tests/a.py::x", "call", stop - start, False, cpu=cpu)
        phase.start, phase.stop = start, stop
        if worker is not None:  # pytest-xdist's controller sets the worker's node
            phase.node = SimpleNamespace(gateway=SimpleNamespace(id=worker))
        return phase

    reports = [on("gw1", 100.0, 130.0, 20.0), on("gw0", 101.0, 102.0, 1.0),
               on("gw0", 102.0, 190.0, 80.0), on("gw1", 130.0, 170.0, 35.0)]
    assert worker_seconds(reports) == {"gw0": (101.0, 190.0, pytest.approx(81.0)),
                                       "gw1": (100.0, 170.0, pytest.approx(55.0))}
    assert worker_seconds([on(None, 5.0, 6.0, 0.5)]) == {"master": (5.0, 6.0, 0.5)}
    assert worker_seconds([]) == {}


def test_cpu_seconds_count_a_waited_subprocess() -> None:
    """A subprocess's CPU counts once it is waited for (the sweep's, the examples')."""
    before = cpu_seconds()
    subprocess.run([sys.executable, "-c", "sum(range(5 * 10**7))"], check=True)
    assert cpu_seconds() - before > 0.2  # at least the child's loop: some 0.5-1 s of a core



def test_each_phase_report_carries_its_cpu_seconds(tmp_path: Path) -> None:
    """End to end: a run with tests/conftest.py as a plugin puts each phase's CPU
    seconds into its report's ``user_properties`` (JUnit XML writes the teardown
    report's) and sums them in the summary, the test's loop included."""
    (tmp_path / "test_busy.py").write_text(
        "def test_busy():\n    assert sum(range(2 * 10**7)) > 0\n")
    xml = tmp_path / "junit.xml"
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "tests.conftest",
                           "-p", "no:cacheprovider", "-p", "no:xdist", f"--junitxml={xml}",
                           "--rootdir", str(tmp_path), str(tmp_path / "test_busy.py")],
                          cwd=ROOT, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    properties = ElementTree.parse(xml).getroot().iter("property")
    teardown = [float(p.get("value", "nan")) for p in properties if p.get("name") == CPU_KEY]
    assert len(teardown) == 1 and teardown[0] >= 0.0
    summary = re.search(r"fast: 1 tests, [0-9.]+ s \(CPU ([0-9.]+) s\)", done.stdout)
    assert summary is not None, done.stdout
    assert float(summary.group(1)) > 0.05  # the loop: some 0.2-0.5 s of a core
    module = re.search(r"test_busy.py: 1 tests, [0-9.]+ s \(CPU ([0-9.]+) s\)", done.stdout)
    assert module is not None, done.stdout
    assert module.group(1) == summary.group(1)  # one module: the tier's seconds
