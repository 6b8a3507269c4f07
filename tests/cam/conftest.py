"""Shared fixtures of the cam tests.

``chain_small``: the whole ``impeller-cam run`` chain on the ``small`` fixture with
coarse settings, once per test run (shared by the xdist workers; about 2 minutes on
one core); returns the output folder. Other tests (the report) read its files; they
must not modify them. When ``cam.report`` is not in this build the report stage
fails (as it should) and the fixture still returns the folder with every other stage
done.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
SMALL_SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
CHAIN_MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
#: Coarse settings of the chain test: every passage roughed and finished.
CHAIN_SETTINGS: dict[str, Any] = {
    "rough_tool": "ball6",
    "finish_tool": "ball4_taper",
    "rough": {"scallop_mm": 1.0, "step_along_mm": 2.0},
    "finish": {"scallop_mm": 0.8, "point_spacing_mm": 1.5},
    "verify_resolution_mm": 0.3,
    "tessellation_mm": 0.05,
}


@pytest.fixture(scope="session")
def chain_small(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> Path:
    """Output folder of the whole chain on the small fixture, built once per test run:
    pytest-xdist workers share it (the first builds it under a lock, the others wait
    and read it)."""
    import fcntl

    from cam.run import run_chain

    root = tmp_path_factory.getbasetemp()
    if worker_id != "master":  # the workers' base folders share a parent
        root = root.parent
    out = root / "chain_small" / "small"
    done = root / "chain_small" / "done"
    with open(root / "chain_small.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not done.exists():
                try:
                    run_chain(SMALL_SPEC, CHAIN_MACHINE, out, progress=False,
                              **CHAIN_SETTINGS)
                except RuntimeError as error:
                    if "cam.report" not in str(error):
                        raise
                done.write_text("built\n")
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
    return out
