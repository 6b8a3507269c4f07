"""``python -m cam.run.warm``: nothing to warm with is said, not an error."""

from __future__ import annotations

from pathlib import Path

import pytest

from cam.run import warm


def test_a_missing_machine_is_reported_and_nothing_runs(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    missing = tmp_path / "no-machine.toml"
    assert warm.main([str(missing)]) == 0
    assert f"numba kernels not warmed: {missing} not found" in capsys.readouterr().err


def test_the_warm_up_spec_and_machine_are_the_checkouts() -> None:
    assert warm.SMALL_SPEC.is_file() and warm.TRUNNION.is_file()
    assert warm.STAGES[0] == "geometry" and "report" not in warm.STAGES


def test_the_dexel_growth_step_compacts_a_grid() -> None:
    """The warm-up's pool growth keeps the grid's one interval (1 mm^3) in a larger
    pool."""
    grid = warm.warm_dexel_growth()
    assert grid.volume() == pytest.approx(1.0, abs=1e-12)
    assert len(grid.lo) >= 1024 and int(grid.used[0]) >= 1


def test_the_test_only_kernels_are_compiled_by_the_warm_up() -> None:
    """tests/warm_kernels.py also compiles the kernels only tests call from Python."""
    from cam.collision.gjk import gjk_interval
    from tests.warm_kernels import warm_test_kernels

    assert warm_test_kernels() >= 0.0
    assert gjk_interval.signatures  # the test's call compiled (or loaded) its kernel
