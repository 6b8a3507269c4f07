"""Roughing as one program per operation (issue 25): one NC program with one tool call,
every UMR visit a section, against the one-file-per-visit layout.

On one passage of the nine-blade fixture's roughing (coarse; several UMRs, one visit
per UMR and layer): the one program
holds the visits' APT operations in cut order, posts into a program with one
``T.. M6`` that rs274 accepts, and removes the same volume from the blank as the
per-visit programs run in sequence, with a clean verification (no gouge,
shank/holder collision, over-travel or rapid in stock). The machine is trunnion-500
without its ``[model]`` tables: the layout of the programs is under test, not the
machine model's fit (planned and verified on the chain, tests/cam/run/
test_machine_chain.py), which would check every move of both layouts against the
machine's solids once more.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cam.roughing.command import run_rough
from cam.roughing.options import RoughOptions
from impeller_cam.errors import InputError
from postproc.apt import read_apt, write_apt
from tests.cam.conftest import TRUNNION, without_model

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures/impellers/nine_blade/spec.toml"
MACHINE = without_model(TRUNNION)


def test_program_layout_is_validated() -> None:
    assert RoughOptions().program_layout == "operation"
    assert RoughOptions(program_layout="visit").program_layout == "visit"
    with pytest.raises(InputError, match="program layout"):
        RoughOptions(program_layout="umr")


@pytest.mark.slow
def test_one_program_per_operation_removes_what_the_visits_remove(tmp_path: Path) -> None:
    from cam.verify.command import VerifyOptions, run_verify
    from postproc.command import post_text
    from tests.postproc.post_check import require_rs274
    from tests.rs274_runner import run_rs274

    require_rs274()
    out = tmp_path / "rough"
    doc = run_rough(SPEC, MACHINE, "ball10", out, progress=False,
                    options=RoughOptions(passages=1, step_along_mm=2.0, scallop_mm=1.0))
    assert [op["apt"] for op in doc["operations"]] == ["rough.apt"]
    visits = read_apt(out / "rough.apt")
    sections = doc["operations"][0]["sections"]
    assert [v.name for v in visits] == [s["name"] for s in sections]
    assert len(visits) > 1, "the test needs several visits"
    # the one program: one tool call, rs274 accepts it
    one = tmp_path / "rough.ngc"
    one.write_text(post_text(out / "rough.apt", MACHINE, post="linuxcnc"))
    assert one.read_text().count(" M6") == 1
    assert len(run_rs274(one).feed) > 100
    # the earlier layout: one file per visit, each its own program and tool call
    per_visit = []
    for visit in visits:
        apt = write_apt(tmp_path / f"{visit.name}.apt", [visit])
        nc = tmp_path / f"{visit.name}.ngc"
        nc.write_text(post_text(apt, MACHINE, post="linuxcnc"))
        assert nc.read_text().count(" M6") == 1
        per_visit.append(nc)
    allowance = doc["finishing_allowance_mm"] + doc["options"]["scallop_mm"]
    removed = []
    for name, programs in (("one", [one]), ("visits", per_visit)):
        run_verify(programs, MACHINE, "ball10", str(SPEC), SPEC, 1.0, tmp_path / name,
                   options=VerifyOptions(allowance=allowance, render=False), progress=False)
        report = json.loads((tmp_path / name / "verify.json").read_text())
        for kind in ("gouge", "holder_collision", "rapid_in_stock", "overtravel"):
            assert report["event_counts"][kind] == 0, (name, report["event_counts"])
        removed.append(report["removed_volume_mm3"])
    assert removed[0] > 0
    assert removed[0] == pytest.approx(removed[1], rel=1e-9)
