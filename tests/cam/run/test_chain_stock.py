"""Issue 18's acceptance: the chain finishes against the verified rough stock.

The whole chain (``impeller-cam run``) on nine_blade and on the splitter with the
specs' own ``[machining]`` settings (the chain now roughs with the depth layers) and
the verification at 0.2 mm (nine_blade; the spec's 0.1 mm is the main job) and the
spec's 0.3 mm (splitter). Verification of the finish programs must report no
shank/holder event, no gouge, no over-travel and no rapid in stock, and the finished
blades and hub must be within allowance + scallop (regions.json ``accepted``).
Tens of minutes each on two cores: run with ``pytest --acceptance``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[3]
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
RUNS: dict[str, dict[str, Any]] = {
    "nine_blade": {"verify_resolution_mm": 0.2},
    "splitter": {},
}


def check_chain(out: Path) -> None:
    """The acceptance checks on one chain's output folder."""
    def load(relative: str) -> dict[str, Any]:
        data = json.loads((out / relative).read_text())
        assert isinstance(data, dict)
        return data

    assert load("rough/rough.json")["options"]["umr_layering"] == "depth"
    finish = load("finish/finish.json")
    assert finish["stock"]["source"].endswith("verify/rough/stock.npz")
    assert finish["stock"]["paths_blocked_by_stock"] == []
    counts = load("verify/finish/verify.json")["event_counts"]
    for kind in ("holder_collision", "gouge", "overtravel", "rapid_in_stock"):
        assert counts[kind] == 0, (kind, counts)
    regions = load("verify/regions.json")["finish"]
    assert not regions["gouge"]
    # issue 18: blades and hub within allowance + scallop (the verdict over every milled
    # face, fillets and edges too, is issue 28's; the splitters' sides are groups of
    # their own, splitter_<side>)
    sides = {r: t for r, t in regions["acceptance"].items()
             if r in ("pressure", "suction", "hub", "splitter_pressure", "splitter_suction")}
    assert {"pressure", "suction", "hub"} <= set(sides)
    assert all(t["within_limit"] for t in sides.values()), {
        r: t["max_mm"] for r, t in sides.items()}


@pytest.mark.slow
@pytest.mark.acceptance
@pytest.mark.parametrize("name", sorted(RUNS))
def test_chain_finishes_clean_against_the_rough_stock(name: str, tmp_path: Path) -> None:
    from cam.run import run_chain

    out = tmp_path / name
    try:
        run_chain(ROOT / "fixtures" / "impellers" / name / "spec.toml", MACHINE, out,
                  progress=False, **RUNS[name])
    except RuntimeError as error:  # a build without cam.report: every other stage ran
        if "cam.report" not in str(error):
            raise
    check_chain(out)
