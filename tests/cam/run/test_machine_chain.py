"""The small fixture's chain plans around the machine model and verifies clean (issue 29).

On trunnion-500 the session's ``chain_small`` is read; on LinuxCNC's sim xyzac-trt
(the vismach model's sizes) the chain runs once more up to the verify stage (slow).
Planning and verification agree: the programs verify with no ``machine_collision``,
and the smallest clearance finishing planned per operation is what the verifier
measured on the posted program, within the sampling step.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.cam.conftest import CHAIN_SETTINGS, ROOT, SMALL_SPEC

XYZAC = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


def load(out: Path, rel: str) -> dict[str, Any]:
    data = json.loads((out / rel).read_text())
    assert isinstance(data, dict)
    return data


def _assert_clean_and_agreeing(out: Path) -> None:
    for kind in ("rough", "finish"):
        data = load(out, f"verify/{kind}/verify.json")
        assert data["event_counts"]["machine_collision"] == 0, (kind, data["event_counts"])
        for program in data["programs"]:
            clearance = program["machine_clearance_mm"]
            assert clearance is None or clearance >= 2.0, program
    finish = load(out, "finish/finish.json")
    machine = finish["machine_model"]
    assert machine is not None and not machine["paths_blocked"]
    verified = {p["name"].rsplit(".", 1)[0]: p for p in
                load(out, "verify/finish/verify.json")["programs"]}
    step = machine["step_mm"]
    for op, entry in machine["operations"].items():
        assert entry["machine_collision_moves"] == 0, (op, entry)
        measured = verified[f"finish_{op}"]["machine_clearance_mm"]
        # the same solids and poses, sampled a little differently (the post's extra
        # points): the planned and the verified smallest clearance within the step
        assert entry["machine_clearance_mm"] == pytest.approx(measured, abs=step), op
    rough = load(out, "rough/rough.json")["machine"]
    assert rough is not None and rough["machine_clearance_mm"] >= 2.0


def test_the_small_chain_on_trunnion_500_has_no_machine_collision(chain_small: Path
                                                                   ) -> None:
    _assert_clean_and_agreeing(chain_small)


@pytest.mark.slow
def test_the_small_chain_on_xyzac_trt_has_no_machine_collision(
        tmp_path_factory: pytest.TempPathFactory) -> None:
    from cam.run import run_chain

    out = tmp_path_factory.mktemp("xyzac") / "small"
    for stage in ("geometry", "rough", "finish", "post", "verify"):
        run_chain(SMALL_SPEC, XYZAC, out, progress=False, only=stage, **CHAIN_SETTINGS)
    _assert_clean_and_agreeing(out)
