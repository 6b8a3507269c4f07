"""The 3+2 shank and holder kept out of the stock left so far (hand-computed cases).

A box blank (|x|, |y| <= 50, z <= 10), a ball of R = 2 and one tool step above it
(the shank from 3 mm above the ball centre, radius 2 or 1). One earlier run plunges
at the origin and clears a pocket within R of the square |x|, |y| <= 1 down to z = 0
(``_plunged``): a shank at the origin, tested CLEARANCE outside its radius 2, is in
air there.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cam.roughing.dropcutter import DropCutter
from cam.roughing.shank import MARGIN, ShankGuard, shank_floor, shank_steps
from cam.roughing.stockmap import ZMap
from cam.roughing.sweptstock import SweptStock
from cam.tools import resolve_tool
from tests.cam.test_roughing_formulas import _BoxBlank, _flat

R = 2.0


def _zmap() -> ZMap:
    return ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(10.0), R)


def _plunged() -> SweptStock:
    """A plunge at the origin to z = 0, then a zigzag there over |x|, |y| <= 1: with
    the tool's column it removes everything within R of that square, down to z = 0."""
    run = np.array([[0.0, 0.0, 20.0], [0.0, 0.0, 0.0], [-1, -1, 0], [1, -1, 0], [1, 0, 0],
                    [-1, 0, 0], [-1, 1, 0], [1, 1, 0]], dtype=float)
    axes = np.tile([0.0, 0.0, 1.0], (len(run), 1))
    return SweptStock(_BoxBlank(), R, 30.0, [run], [axes])  # type: ignore[arg-type]


def _world(points: np.ndarray) -> np.ndarray:
    return points  # the frame is W here (axis +Z)


def test_zmap_highest_stock_within_a_radius() -> None:
    zmap = _zmap()
    assert zmap.highest(np.array([[0.0, 0.0]]), 3.0)[0] == pytest.approx(10.0)
    # a ball swept along x at centre height 5: the floor at |y| <= 2 is 5 - sqrt(4 - y^2)
    zmap.sweep(np.column_stack([np.linspace(-10, 10, 41), np.zeros(41), np.full(41, 5.0)]))
    # nodes every 0.5 mm: within 1 of the origin the highest is at |y| = 1
    assert zmap.highest(np.array([[0.0, 0.0]]), 1.0)[0] == pytest.approx(5.0 - math.sqrt(3.0))
    # within 2.2: the groove's rim at |y| = 2 (5 - 0); within 2.6 the uncut blank
    assert zmap.highest(np.array([[0.0, 0.0]]), 2.2)[0] == pytest.approx(5.0)
    assert zmap.highest(np.array([[0.0, 0.0]]), 2.6)[0] == pytest.approx(10.0)
    assert zmap.highest(np.array([[100.0, 0.0]]), 1.0)[0] == -np.inf  # off the map


def test_shank_steps_of_a_library_tool() -> None:
    tool = resolve_tool("ball6")  # flutes 14, shank 6 to 40, holder 14 -> 19 mm wide
    steps = shank_steps(tool)
    assert steps[0] == pytest.approx((14.0 - 3.0, 3.0))
    assert steps[1] == pytest.approx((40.0 - 3.0, 9.5))


def test_shank_in_a_cut_pocket_stays() -> None:
    """At the origin the shank (radius 2) lies in the cut pocket: the Z-map, which
    knows no cut, flags it (limit 10 - 3 = 7); the swept stock clears it."""
    z, lifted = shank_floor(np.array([[0.0, 0.0, 0.0]]), [(3.0, R)], _zmap(), R, _world,
                            _plunged(), before=1)
    assert lifted == 0 and z[0] == 0.0
    # without the swept stock the Z-map's limit stands: the shank's bottom at the top
    z, lifted = shank_floor(np.array([[0.0, 0.0, 0.0]]), [(3.0, R)], _zmap(), R, _world,
                            None)
    assert lifted == 1 and z[0] == pytest.approx(7.0)
    # before the pocket (run 0 not yet cut) it is stock
    z, lifted = shank_floor(np.array([[0.0, 0.0, 0.0]]), [(3.0, R)], _zmap(), R, _world,
                            _plunged(), before=0)
    assert lifted == 1 and z[0] == pytest.approx(7.0)


def test_shank_beside_the_pocket_is_lifted_out_of_the_stock() -> None:
    """1.2 mm off the axis the shank reaches x = 3.2 (and its tested ring 3.35), past
    the pocket's wall at x = 3: stock up to the blank top, so the ball centre must rise
    until the shank's bottom is at 10: z = 7. 0.7 mm off it, the ring reaches 2.85:
    clear (the swept stock's samples, 1 mm apart, reach it within R)."""
    z, lifted = shank_floor(np.array([[1.2, 0.0, 0.0], [0.0, 0.0, 8.0], [0.7, 0.0, 0.0]]),
                            [(3.0, R)],
                            _zmap(), R, _world, _plunged(), before=1)
    assert lifted == 1
    assert z[0] == pytest.approx(7.0) and z[1] == 8.0  # above the blank: left alone
    assert z[2] == 0.0


def test_thin_neck_in_a_groove_the_zmap_knows() -> None:
    """A neck of radius 1 over a groove cut along x at centre height 5: the highest
    node within 1 + MARGIN of the axis is at |y| = 1.5, 5 - sqrt(4 - 1.5^2) high; the
    neck's bottom (3 above the ball centre) must clear it."""
    zmap = _zmap()
    zmap.sweep(np.column_stack([np.linspace(-10, 10, 41), np.zeros(41), np.full(41, 5.0)]))
    assert MARGIN == 0.5
    top = 5.0 - math.sqrt(4.0 - 1.5 ** 2)
    z, lifted = shank_floor(np.array([[0.0, 0.0, -5.0]]), [(3.0, 1.0)], zmap, R, _world, None)
    assert lifted == 1 and z[0] == pytest.approx(top - 3.0)


def test_guard_drop_keeps_clear_points_and_lifts_the_others() -> None:
    base = DropCutter(_flat(-100.0), R)  # far below: the stock alone decides
    guard = ShankGuard(base, [(3.0, R)], _zmap(), R, _world, _plunged(), before=1)
    drop = guard.drop(np.array([[1.2, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 5.0, 9.0]]))
    assert drop[0] == pytest.approx(7.0) and drop[1] == 0.0 and drop[2] == 9.0
    assert guard.lifted == 1
