"""Test-suite wide notes: how the tests share the two workers, and the tiers.

``scripts/test`` runs ``pytest -n 2 --dist loadscope``: the tests of one module run on
one worker, so a module-scoped fixture (nine_blade's roughing run) is built once. The
small fixture's whole chain (``chain_small``, tests/cam/conftest.py), used by several
modules, is built once for both workers, in the base folder they share, under a lock.
(pytest-xdist's ``xdist_group`` marks did not group anything with pytest 9: the
worker's node ids no longer take its group suffix.)

Tiers: ``-m "not slow"`` is the fast tier (unit, property and the small fixture's
chain); ``slow`` marks the acceptance runs on the nine_blade and splitter fixtures,
LinuxCNC's impeller demo and other tests that take more than about 15 s of a core.
``acceptance`` marks whole main-job-size chains (tens of minutes each): they run only
with ``pytest --acceptance``.
"""

from __future__ import annotations

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--acceptance", action="store_true", default=False,
                     help="also run the whole-chain acceptance runs (marker 'acceptance')")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--acceptance"):
        return
    skip = pytest.mark.skip(reason="whole-chain acceptance run: pytest --acceptance")
    for item in items:
        if "acceptance" in item.keywords:
            item.add_marker(skip)
