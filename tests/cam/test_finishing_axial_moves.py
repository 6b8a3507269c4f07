"""An operation's way in and out along the tool axis (cam/finishing/axial_moves.py).

The chain's nine_blade with ``ball6_flank3`` came down its first hub pass's axis from
the clearance cylinder as one rapid the link check had refused: the verification found
a rapid in the stock's skin (16.4 mm3, 4.2 mm deep), which the wide upper flutes (5.2
mm radius at the top of 45 mm, over a 3 mm ball) swept. Here a slab of excess stock
stands beside the first pass's way in and the last pass's way out, out of the ball's
reach at the pass's ends and in the flutes' on the way: no rapid may cross it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from cam.collision import CollisionScene
from cam.finishing.axial_moves import FRACTIONS
from cam.finishing.command import _check_links
from cam.finishing.linking import Envelope, Linker
from cam.finishing.options import FinishOptions
from cam.finishing.stock_clearance import StockExcess, StockScene
from cam.tools import resolve_tool
from postproc.toolpath import Cutter, MoveKind, Toolpath
from tests.cam.test_finishing_links import KINS, _cylinder, _linker, _passes

FLANK = resolve_tool("ball6_flank3")
PITCH = 0.5


def _flank_linker(scene: CollisionScene) -> Linker:
    rules = replace(_linker(scene).rules, tool=FLANK, envelope=Envelope(70.0, 90.0))
    return Linker(scene, KINS, rules)


def _slab(tip: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Voxel indices (pitch ``PITCH``, origin 0) of a slab beside the axis line through
    ``tip`` (a pass's end): 4.0-5.0 mm off it, 16 mm wide, 10-30 mm up the axis. A
    tapered flute's radius passes 3.5 mm (4.0 grown by the rapid clearance) 12.5 mm
    above the tip: postures near the pass's end have their flutes in it, the ball and
    a posture 30 mm further out along the axis do not."""
    side = np.cross(axis, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    across = np.cross(axis, side)
    a, s, c = np.meshgrid(np.arange(9.0, 31.0, PITCH / 2), np.arange(3.0, 6.0, PITCH / 2),
                          np.arange(-9.0, 9.0, PITCH / 2), indexing="ij")
    points = tip + a.reshape(-1, 1) * axis + s.reshape(-1, 1) * side \
        + c.reshape(-1, 1) * across
    index = np.unique(np.floor(points / PITCH).astype(np.int64), axis=0)
    centre = (index + 0.5) * PITCH - tip
    along, off, wide = centre @ axis, centre @ side, centre @ across
    keep = (along > 10.0) & (along < 30.0) & (off > 4.0) & (off < 5.0) & (np.abs(wide) < 8.0)
    return np.asarray(index[keep])


def _rapid_clear(scene: CollisionScene, linker: Linker, tip: np.ndarray,
                 axis: np.ndarray) -> bool:
    r = linker.rules
    report = scene.check_motion(FLANK, tip, axis, max_step_mm=r.step_mm, max_step_deg=0.5,
                                cutter_allowance=-r.clearance, clearance_cap=r.clearance)
    return not bool(report.blocked(r.clearance).any())


def test_no_rapid_crosses_the_stock_on_the_way_in_or_out() -> None:
    design = _cylinder(20.0, 30.0)
    one = _passes()[0]  # one pass: its way in and its way out
    index = np.unique(np.vstack([_slab(one.tip[0], one.axis[0]),
                                 _slab(one.tip[-1], one.axis[-1])]), axis=0)
    excess = StockExcess(index, np.zeros(3), PITCH, np.full(len(index), 5.0), 0.0, len(index))
    scene = StockScene(design, excess)
    cutter = Cutter(FLANK.diameter, FLANK.corner_radius, FLANK.flute_length)
    options = replace(FinishOptions(), clearance_mm=0.5, motion_step_deg=0.5)
    linker = _flank_linker(scene)
    # the chain's case: no departure keeps the grown flutes out of the stock, the one
    # kept (``Linker._cutter_escape``) checks the cutter as a cut
    linker.escape = lambda tip, axis, normal: (tip + 2.0 * axis, 2.0)  # type: ignore[method-assign]
    toolpath, air, _ = linker.join("stock", [one], tool_number=1, cutter=cutter,
                                   spindle_rpm=None)
    kind, feed, tip, axis = toolpath.kind, toolpath.feed, toolpath.tip, toolpath.axis
    entry, leave = one.tip[0] + 2.0 * one.axis[0], one.tip[-1] + 2.0 * one.axis[-1]
    # the way in and out as single rapids (as before) would run the flutes through it
    assert not _rapid_clear(scene, linker, np.stack([tip[0], entry]), axis[:2])
    assert not _rapid_clear(scene, linker, np.stack([leave, tip[-1]]), axis[-2:])
    # way in: a checked rapid part of the way, the rest at half the feed
    assert kind[1] == MoveKind.RAPID and toolpath.link[1]
    assert kind[2] == MoveKind.PLUNGE and feed[2] == pytest.approx(500.0)
    np.testing.assert_allclose(tip[2], entry, atol=1e-9)
    share = np.linalg.norm(tip[1] - tip[0]) / np.linalg.norm(entry - tip[0])
    assert min(abs(share - f) for f in FRACTIONS[1:]) < 1e-9
    # way out: at half the feed, then a checked rapid to the cylinder point
    assert kind[-2] == MoveKind.RETRACT and feed[-2] == pytest.approx(500.0)
    assert kind[-1] == MoveKind.RAPID and toolpath.link[-1]
    np.testing.assert_allclose(tip[-3], leave, atol=1e-9)
    # every rapid after the start is a checked link, clear as a rapid (the whole tool,
    # the flutes grown by the clearance, against design and stock)
    rapids = np.flatnonzero(kind[1:] == MoveKind.RAPID) + 1
    assert toolpath.link[rapids].all()
    for row in rapids:
        assert _rapid_clear(scene, linker, tip[row - 1:row + 1], axis[row - 1:row + 1])
    assert _check_links(scene, FLANK, toolpath, air, options) == 0
    # the defect: the way in as one unflagged straight rapid is counted by the check
    bad = Toolpath(tip=np.delete(tip, 1, axis=0), axis=np.delete(axis, 1, axis=0),
                   feed=np.delete(feed, 1), kind=np.delete(kind, 1), name="bad",
                   tool_number=1, cutter=cutter, spindle_rpm=None,
                   link=np.delete(toolpath.link, 1))
    bad.kind[1], bad.feed[1] = MoveKind.RAPID, math.nan
    assert _check_links(scene, FLANK, bad, np.delete(air, 1), options) > 0
