"""The per-tier seconds of the terminal summary (tests/conftest.py ``tier_seconds``)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from tests.conftest import tier_seconds


def report(nodeid: str, when: str, duration: float, slow: bool) -> SimpleNamespace:
    keywords = {"slow": 1} if slow else {}
    return SimpleNamespace(nodeid=nodeid, when=when, duration=duration, keywords=keywords)


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
