"""Issue 28 on a design the chain was not tuned on: round trailing edges, a thickness law.

The chain (``impeller-cam run``, its stages up to verify: motion and report only read
their outputs; about 4 % of the run) on ``fixtures/impellers/round_te`` (six blades,
round trailing edges, the design generator's thickness law) at the chain test's coarse
settings: every milled face (pressure, suction, hub, the strips next to the fillets,
the fillets, the leading and the round trailing edges) within allowance + scallop +
tolerance, the verdict accepted, no stock short, no gouge, no shank/holder event.
Measured (2026-11-27, 21b3353): every face within the 0.85 mm limit, the largest the
leading edge's 0.502 mm; the round trailing edge 0.258 mm.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS, ROOT

SPEC = ROOT / "fixtures" / "impellers" / "round_te" / "spec.toml"


@pytest.mark.slow
def test_every_milled_face_of_the_round_te_design_is_finished(tmp_path: Path) -> None:
    from cam.run import run_chain

    out = tmp_path / "round_te"
    # the stages up to the verdict (verify); motion and report only read their outputs
    for stage in ("geometry", "rough", "finish", "post", "verify"):
        run_chain(SPEC, CHAIN_MACHINE, out, progress=False, only=stage, **CHAIN_SETTINGS)

    def load(relative: str) -> dict[str, Any]:
        data = json.loads((out / relative).read_text())
        assert isinstance(data, dict)
        return data

    finish = load("verify/regions.json")["finish"]
    faces = finish["acceptance"]
    assert {"pressure", "suction", "hub", "pressure_near_fillet", "suction_near_fillet",
            "hub_near_fillet", "fillet", "leading_edge", "trailing_edge"} <= set(faces)
    for name, table in faces.items():
        assert table["within_limit"], (name, table)
        assert table["max_mm"] <= finish["limit_mm"], (name, table)
    assert finish["accepted"] and finish["failed"] == []
    assert finish["stock_short_samples"] == 0 and not finish["gouge"]
    for kind in ("rough", "finish"):
        counts = load(f"verify/{kind}/verify.json")["event_counts"]
        for event in ("stock_short", "gouge", "holder_collision", "overtravel",
                      "rapid_in_stock"):
            assert counts.get(event, 0) == 0, (kind, event, counts)
