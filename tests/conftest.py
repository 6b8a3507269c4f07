"""Test-suite wide set-up: how pytest-xdist shares the tests between workers.

``scripts/test`` runs ``pytest -n 2 --dist loadgroup``. A module- or session-scoped
fixture (a roughing run of nine_blade, the chain on the small fixture) is built once
per worker that runs a test needing it, so tests that share one must run on one
worker: every test is put in the group of its module, and every test of the chain on
the small fixture (``chain_small``, several modules) in one group. A test may name
its group itself (``pytest.mark.xdist_group``).

Tiers: ``-m "not slow"`` is the fast tier (unit, property and the small fixture's
chain); ``slow`` marks the acceptance runs on the nine_blade and splitter fixtures
and other tests that take more than about ten seconds of a core.
"""

from __future__ import annotations

import pytest

#: Tests using this session fixture (tests/cam/conftest.py) share one worker.
CHAIN_FIXTURE = "chain_small"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Give every test an ``xdist_group``: its module's, or the small chain's."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        if CHAIN_FIXTURE in getattr(item, "fixturenames", ()):
            group = CHAIN_FIXTURE
        else:
            group = item.nodeid.split("::", 1)[0]
        item.add_marker(pytest.mark.xdist_group(group))
