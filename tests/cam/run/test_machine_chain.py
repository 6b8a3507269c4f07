"""The small fixture's chain plans around the machine model (issue 29).

On LinuxCNC's sim xyzac-trt (the vismach model's sizes) the small chain runs up to
the verify stage (slow), two of its six passages roughed and finished: on the C axis
turn only the round platter and the part, which the pitch maps onto itself, so a
passage's machine postures are the first passage's with C turned by the pitch (the
same distances between every pair of solids), and two passages keep an index move
between passages in each program (about a third of the six passages' time). (On
trunnion-500 the small part does not fit with the library's short tools: the finish
stage refuses it before planning, ``tests/cam/test_machine_reach.py``.)
Planning and verification agree: the smallest clearance finishing planned per
operation is what the verifier measured on the posted program (within the sampling
step), an operation planning found clean verifies clean, and on xyzac-trt every
program verifies with no ``machine_collision``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.cam.conftest import CHAIN_SETTINGS, ROOT, SMALL_SPEC

XYZAC = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
#: The chain test's coarse settings, two passages roughed and finished (module docstring).
TWO_PASSAGES: dict[str, Any] = {
    **CHAIN_SETTINGS,
    "rough": {**CHAIN_SETTINGS["rough"], "passages": 2},
    "finish": {**CHAIN_SETTINGS["finish"], "passages": 2},
}


def load(out: Path, rel: str) -> dict[str, Any]:
    data = json.loads((out / rel).read_text())
    assert isinstance(data, dict)
    return data


def _machine_events(out: Path, kind: str) -> dict[str, int]:
    data = load(out, f"verify/{kind}/verify.json")
    counts = {p["name"].rsplit(".", 1)[0]: 0 for p in data["programs"]}
    for event in data["events"]:
        if event["type"] == "machine_collision":
            counts[event["program"].rsplit(".", 1)[0]] += 1
    assert sum(counts.values()) == data["event_counts"]["machine_collision"]  # not capped
    return counts


def _assert_agreeing(out: Path, clean: bool) -> None:
    """Planning's machine entries say what verification finds (and, ``clean``: none)."""
    finish = load(out, "finish/finish.json")
    machine = finish["machine_model"]
    assert machine is not None
    verified = {p["name"].rsplit(".", 1)[0]: p for p in
                load(out, "verify/finish/verify.json")["programs"]}
    events = _machine_events(out, "finish")
    step = machine["step_mm"]
    for op, entry in machine["operations"].items():
        name = f"finish_{op}"
        # the same solids and poses, sampled a little differently (the post's extra
        # points): the planned and the verified smallest clearance within the step
        assert entry["machine_clearance_mm"] == pytest.approx(
            verified[name]["machine_clearance_mm"], abs=step), op
        assert (entry["machine_collision_moves"] == 0) == (events[name] == 0), (op, entry)
    rough = load(out, "rough/rough.json")["machine"]
    assert rough is not None
    assert (rough["machine_collisions"] == 0) == (_machine_events(out, "rough")["rough"] == 0)
    if clean:
        assert not machine["paths_blocked"]
        assert sum(events.values()) == 0 and rough["machine_collisions"] == 0


@pytest.mark.slow
def test_the_small_chain_on_xyzac_trt_has_no_machine_collision(
        tmp_path_factory: pytest.TempPathFactory) -> None:
    from cam.run import run_chain

    out = tmp_path_factory.mktemp("xyzac") / "small"
    for stage in ("geometry", "rough", "finish", "post", "verify"):
        run_chain(SMALL_SPEC, XYZAC, out, progress=False, only=stage, **TWO_PASSAGES)
    _assert_agreeing(out, clean=True)
