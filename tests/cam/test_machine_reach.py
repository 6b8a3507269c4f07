"""Finishing that cannot fit the machine fails fast, with what would fit (issue 29).

The small part on trunnion-500 with the library's short ball4_taper (125 mm gauge
length): at A -82 to -96 deg the 500 mm class head meets the platter and the cutter's
shank the mandrel nut, whatever posture the eq. 7 remedy and the repair cone may
choose. ``run_finish`` refuses it before any per-point planning (``InputError``, exit
2, nothing written), naming the operation, paths, passages, A range and the closest
pairs, and the holder gauge length and the riser height that would fit - computed with
the same query, so they are checked here: at the reported value every spindle-side
posture has a clearing candidate, 1 mm less does not.
The main job (nine_blade, ball6_taper) passes the same check.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam.finishing import machine_reach as reach_mod
from cam.finishing.command import run_finish
from impeller_cam.errors import InputError
from tests.cam.conftest import CHAIN_SETTINGS, ROOT, SMALL_SPEC, TRUNNION, finishing_setup

NINE_BLADE = ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml"
#: The chain test's coarse finishing.
COARSE: dict[str, Any] = CHAIN_SETTINGS["finish"]


@pytest.mark.slow  # about 30 s of a core: the passes and the reach survey come first
def test_the_small_part_on_trunnion_500_is_refused_before_planning(tmp_path: Path) -> None:
    out = tmp_path / "finish"
    with pytest.raises(InputError) as caught:
        run_finish(SMALL_SPEC, TRUNNION, "ball4_taper", out, scene="surfaces", plots=False,
                   progress=False, passages=1, **COARSE)
    text = str(caught.value)
    assert not out.exists()
    assert "trunnion-500.toml" in text and "field 'model'" in text
    for op in ("junction", "blade", "hub"):
        assert f"operation {op}: " in text
    assert "spindle_head - rotary_table" in text and "mandrel_nut" in text
    tilts = [float(a) for a in re.findall(r"A (-?\d+\.\d) to", text)]
    assert tilts and all(-100.0 < a < -75.0 for a in tilts)
    gauge = re.search(r"gauge length of at least (\d+) mm \(ball4_taper: 125 mm", text)
    riser = re.search(r"the part (\d+) mm higher on its riser", text)
    assert gauge is not None and riser is not None
    assert 125 < int(gauge.group(1)) < 125 + reach_mod.REMEDY_LIMIT


def test_the_remedies_are_the_smallest_that_fit() -> None:
    """At the computed holder extension every spindle-side posture has a clearing
    candidate (the cutter's own pairs aside); 1 mm shorter, some has none."""
    s = finishing_setup(SMALL_SPEC, "ball4_taper")
    obstacle, tool = s["obstacle"], s["tool"]
    # the repair's preferred cone only: with the default 30 deg cone the candidates of
    # these postures clear their spindle-side pairs at the tool's own gauge length
    # (the extension found, 1 mm, is then not the smallest: nothing to measure)
    options = replace(s["options"], tilt_search_deg=10.0)
    reach = reach_mod.reach_of(obstacle, tool, s["paths"], options)
    side = reach.unreachable & reach_mod.spindle_side(reach)
    assert side.any() and (reach.unreachable & ~side).any()
    fix = reach_mod.remedies(obstacle, tool, reach, options)
    extra = fix["gauge_length_mm"]
    assert extra is not None and fix["riser_mm"] is not None
    rows = np.flatnonzero(side)
    axes = reach_mod.candidates(reach.axis[rows], reach.away[rows], reach.turns[rows],
                                options)

    def clear_with(more: float) -> bool:
        from cam.verify.machine_query import MachineClearance
        from cam.verify.machine_scene import machine_scene

        scene = machine_scene(obstacle.model, reach_mod._longer(tool, more), None,
                              part=obstacle.part)
        scene.pairs = [p for p in scene.pairs if "tool" not in
                       (scene.solids[p[0]].name, scene.solids[p[1]].name)]
        query = MachineClearance(scene, s["kins"], tool_side=True)
        best, _ = reach_mod.best_margin(query, tool.radius, reach.centre[rows], axes,
                                        obstacle.margin)
        return bool((best >= obstacle.margin).all())

    assert clear_with(extra)
    assert not clear_with(extra - reach_mod.REMEDY_STEP)
    # the longer holder keeps the stick-out: the cutter and shank are the same
    longer = reach_mod._longer(tool, extra)
    assert longer.stickout == tool.stickout and longer.length == tool.length + extra


def test_the_main_job_reaches_every_posture() -> None:
    s = finishing_setup(NINE_BLADE, "ball6_taper")
    reach = reach_mod.reach_of(s["obstacle"], s["tool"], s["paths"], s["options"])
    assert reach.postures == sum(len(p) for p in s["paths"])
    assert not reach.unreachable.any()
