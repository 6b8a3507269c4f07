"""Compile the chain's numba kernels into the checkout before the test run.

The kernels are ``numba.njit(cache=True)``: a process compiles a kernel at its first
call unless ``__pycache__`` holds it already. On a fresh clone every pytest worker
(and every worker process a test starts: the sweep's, the examples') would compile the
kernels it reaches before another has written them, the two workers often the same
kernels at the same time (measured: ``test_verify_engine`` and ``test_roughing_blank``
take 39 s of a core on a cold cache, 6 s on a warm one). ``scripts/test`` runs this
module while mypy runs (mypy uses one core), so the tests start with the chain's
kernels compiled once: ``cam.run.warm`` (the small fixture's chain, one passage, the
chain test's coarse settings, every stage that calls kernels, on the tests' machine:
trunnion-500 without its model, ``tests.cam.conftest.CHAIN_MACHINE``; then the finish
stage's reach check on trunnion-500 with its model, which compiles the machine model's
clearance bounds, and a dexel pool's growth). docs/testing.md: checking that a new
kernel is covered.

Then the kernels that only tests call directly from Python (a call from Python
compiles a kernel of its own for the arguments' types, which no product path
compiles): ``gjk_interval``, called by
``tests/cam/test_collision_kernel.py::test_gjk_interval_of_placed_shapes_by_hand``
(about 4 s of a core to compile: 7.0 s of CPU for that test on a cold cache, 3.1 s
on a warm one).

Last, the test modules are collected once (``write_test_bytecode``: ``pytest
--collect-only`` in a subprocess), which writes their assertion-rewritten bytecode into
``__pycache__``: the two pytest workers then read it instead of each rewriting every
test module's asserts while collecting (docs/testing.md, "Bytecode").

Usage: ``python -m tests.warm_kernels`` (prints the seconds it took).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

from cam.run.warm import main


def warm_test_kernels() -> float:
    """Compile the kernels only tests call from Python (module docstring) by running
    those tests' calls; returns the seconds it took."""
    from tests.cam.test_collision_kernel import test_gjk_interval_of_placed_shapes_by_hand

    start = time.monotonic()
    test_gjk_interval_of_placed_shapes_by_hand()
    return time.monotonic() - start


def write_test_bytecode() -> float:
    """Collect the test suite once in a subprocess (``pytest --collect-only``), which
    writes the assertion-rewritten bytecode of every test module and the compiled
    bytecode of what they import (module docstring; nothing is written when the
    environment sets ``PYTHONDONTWRITEBYTECODE``); returns the seconds it took."""
    start = time.monotonic()
    subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                    "-p", "no:cacheprovider"], cwd=Path(__file__).resolve().parents[1],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.monotonic() - start


if __name__ == "__main__":
    code = main([])
    print(f"test-only kernels warmed in {warm_test_kernels():.0f} s", file=sys.stderr)
    print(f"test bytecode written in {write_test_bytecode():.0f} s", file=sys.stderr)
    sys.exit(code)
