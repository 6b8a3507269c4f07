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

Usage: ``python -m tests.warm_kernels`` (prints the seconds it took).
"""

from __future__ import annotations

import sys

from cam.run.warm import main

if __name__ == "__main__":
    sys.exit(main([]))
