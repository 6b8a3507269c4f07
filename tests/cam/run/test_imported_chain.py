"""Issue 22: an impeller exported to BladeGen files and imported again runs through the
chain with the same verification result as the original.

The ``small`` fixture with the chain test's coarse settings, one passage roughed and
finished, runs geometry, rough, finish, post and verify twice: from its own spec and
from the spec that ``impeller-cam import`` made of its BladeGen export (with the
``manufacturing.toml`` the export wrote, so the [machining] settings are the same).
``cam.run.compare`` judges the two folders (docs/import-export.md, "The same
verification result").
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from cam.run import run_chain
from cam.run.compare import FAULT_EVENTS, RunComparison, compare_runs
from tests.cam.conftest import CHAIN_MACHINE, ONE_PASSAGE_SETTINGS, SMALL_SPEC

pytestmark = pytest.mark.slow

#: The stages whose results are compared (motion and report read them only).
STAGES = ("geometry", "rough", "finish", "post", "verify")


def chain(spec: Path, out: Path) -> Path:
    for stage in STAGES:
        run_chain(spec, CHAIN_MACHINE, out, only=stage, progress=False,
                  **ONE_PASSAGE_SETTINGS)
    return out


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("imported_small")
    assert main(["export", str(SMALL_SPEC), "--format", "bladegen",
                 "-o", str(root / "files")]) == 0
    assert main(["import", str(root / "files" / "small.inf"), "-o", str(root / "spec"),
                 "--no-check-solid"]) == 0
    return root / "spec" / "spec.toml"


@pytest.fixture(scope="module")
def comparison(imported: Path, tmp_path_factory: pytest.TempPathFactory) -> RunComparison:
    root = tmp_path_factory.mktemp("imported_chain")
    return compare_runs(chain(SMALL_SPEC, root / "original"),
                        chain(imported, root / "imported"))


def test_the_imported_spec_keeps_every_setting(imported: Path) -> None:
    """Everything but the geometry's numbers is the original's, key for key; the
    contours' numbers are the original's to the written digits."""
    a = tomllib.loads(SMALL_SPEC.read_text())
    b = tomllib.loads(imported.read_text())
    for key in ("meridional",):
        for side in ("hub", "shroud"):
            np.testing.assert_allclose(b[key][side], a[key][side], atol=1e-6)
        a.pop(key), b.pop(key)
    assert a == b


def test_same_verification_result(comparison: RunComparison) -> None:
    assert comparison.same, comparison.table([q.name for q in comparison.differing])
    values = {q.name: q for q in comparison.quantities}
    for run in ("rough", "finish"):
        assert values[f"{run}.accepted"].original is not None
        for kind in FAULT_EVENTS:
            q = values[f"verify.{run}.events.{kind}"]
            assert q.original == q.other
    for stage in STAGES:
        assert values[f"stage.{stage}"].original == values[f"stage.{stage}"].other == "done"


def test_face_deviations_closer_than_the_tolerance(comparison: RunComparison) -> None:
    """The blade differs by micrometres: the milled faces' largest deviations agree
    far better than the allowed geometric difference + dexel spacing."""
    lengths = [q for q in comparison.quantities
               if q.rule == "length" and q.difference is not None]
    assert len(lengths) > 40
    worst = max(abs(q.difference or 0.0) for q in lengths)
    assert worst <= comparison.length_mm
