"""Entries and the rapid proof where the region's Z-map misses stock (hand-computed).

A Z-map is a height field along the region's axis: a face lying almost along the
axis puts a wedge of stock between its nodes that no node sees (the splitter's
inlet face under UMR 1's almost radial axis: a plunge's approach came down 0.27 mm
into it). Here the Z-map is given a blank 2 mm lower (top 8) than the swept stock's
box blank (top 10) to stand for such a miss.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from cam.roughing.aircheck import fixed_axis_rapids
from cam.roughing.dropcutter import DropCutter
from cam.roughing.linking import LinkSettings, entry_moves
from cam.roughing.plan import Segment
from cam.roughing.stockmap import ZMap
from cam.roughing.sweptstock import RAPID_CLEARANCE, SweptStock
from cam.roughing.umr import FixedAxisFrame
from postproc.toolpath import MoveKind
from tests.cam.test_roughing_formulas import _BoxBlank, _flat

R = 2.0
UP = np.array([0.0, 0.0, 1.0])


def test_rise_finds_the_first_height_in_air() -> None:
    """Nothing cut: a ball over the box (top 10) is in air once the tested ball
    (R + 0.25) and its points' margin m clear the top: t >= 12.25 + m, on the 0.25 grid."""
    swept = SweptStock(_BoxBlank(), R, 30.0, [], [])  # type: ignore[arg-type]
    t = swept.rise(np.zeros(3), UP, 0.0, 40.0, before=0)
    lowest = 10.0 + R + RAPID_CLEARANCE + swept.margin
    assert lowest <= t <= lowest + 0.25
    assert swept.rise(np.zeros(3), UP, 0.0, 5.0, before=0) == 5.0  # none below the limit


def test_entry_rises_above_the_zmap_when_the_other_model_finds_stock() -> None:
    design = DropCutter(_flat(-100.0), R)
    stock = ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(8.0), R)
    settings = LinkSettings(entry_height=1.0, entry_angle_deg=90.0)
    start = np.array([0.0, 0.0, 5.0])
    # the map's entry top: its air height 8 + R plus the entry height
    c, k, _ = entry_moves(start, None, design, stock, settings)
    assert c[0, 2] == pytest.approx(11.0)
    # another model knows air down to 9 only: the plunge may start there + 1 ... capped
    # by the map's top (the lower of the two is taken when the map is the higher)
    c, _, _ = entry_moves(start, None, design, stock, settings, lowest=9.0)
    assert c[0, 2] == pytest.approx(10.0)
    # ... but when it finds stock above the map's top (air only from 12.5), the entry
    # starts 1 mm above that
    c, k, _ = entry_moves(start, None, design, stock, settings, lowest=12.5)
    assert c[0, 2] == pytest.approx(13.5) and np.allclose(c[1], start)
    assert k.tolist() == [MoveKind.RAPID, MoveKind.PLUNGE]


def test_rapid_proof_asks_the_swept_stock_near_the_zmaps_air() -> None:
    """A rapid down to ball centre 10.5 over the box (top 10): the Z-map (top 8) sees
    its ball 0.5 mm in air, the swept stock sees it 1.5 mm into the blank: one bad
    rapid. The rapid back up the axis of the plunge is in the plunge's column: air."""
    frame = FixedAxisFrame(UP, _flat(-100.0), R)
    umr = SimpleNamespace(frame=frame)
    centres = np.array([[0, 0, 20.0], [0, 0, 10.5], [0, 0, 5.0], [0, 0, 6.0], [0, 0, 20.0]])
    kind = np.array([MoveKind.RAPID, MoveKind.RAPID, MoveKind.PLUNGE, MoveKind.RETRACT,
                     MoveKind.RAPID], np.int8)
    segment = Segment(centres - R * UP, np.tile(UP, (5, 1)), kind, True, 0, 0)
    zmap = ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(8.0), R)
    bad, rapids, _ = fixed_axis_rapids(segment, umr, [], _BoxBlank(), _flat(8.0), R,  # type: ignore[arg-type]
                                       30.0, zmap)
    assert (bad, rapids) == (1, 2)
    # the same descent stopping at 12.5 (ball bottom 10.5, 0.375 clear of the box with
    # the checked clearance 0.125 mm) is in air
    centres[1, 2] = 12.5
    segment = Segment(centres - R * UP, np.tile(UP, (5, 1)), kind, True, 0, 0)
    zmap = ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(8.0), R)
    bad, rapids, _ = fixed_axis_rapids(segment, umr, [], _BoxBlank(), _flat(8.0), R,  # type: ignore[arg-type]
                                       30.0, zmap)
    assert (bad, rapids) == (0, 2)
