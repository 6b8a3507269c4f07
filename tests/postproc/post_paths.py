"""Synthetic CL paths for the post-processor tests and the fixtures/apt/post_*.apt files.

Run ``python tests/postproc/post_paths.py`` to rewrite the fixture files (only when
the paths below change on purpose; the golden NC files then change too).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from postproc.toolpath import Cutter, MoveKind, Toolpath

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "fixtures" / "apt"


def tilted_axis(tilt_deg: float, turn_deg: float) -> NDArray[np.float64]:
    """Unit axis tilted ``tilt_deg`` from +Z towards the direction ``turn_deg`` in XY."""
    t, c = np.radians(tilt_deg), np.radians(turn_deg)
    return np.array([np.sin(t) * np.sin(c), np.sin(t) * np.cos(c), np.cos(t)])


def roughing_3p2() -> Toolpath:
    """A 3+2 operation: two fixed-orientation segments joined by a rapid re-orientation."""
    tips, axes, kinds, feeds, segs = [], [], [], [], []
    for seg, (tilt, turn, x0) in enumerate([(30.0, 20.0, -10.0), (25.0, 140.0, 5.0)]):
        axis = tilted_axis(tilt, turn)
        zig = [(x0, -6.0), (x0 + 8.0, -6.0), (x0 + 8.0, -3.0), (x0, -3.0), (x0, 0.0),
               (x0 + 8.0, 0.0)]
        points = [np.array([x, y, 22.0]) for x, y in zig]
        above = points[0] + 15.0 * axis
        tips += [above, points[0] + 2.0 * axis] + points + [points[-1] + 15.0 * axis]
        axes += [axis] * (len(points) + 3)
        kinds += [MoveKind.RAPID, MoveKind.RAPID, MoveKind.PLUNGE] + \
            [MoveKind.FEED] * (len(points) - 1) + [MoveKind.RETRACT]
        feeds += [np.nan, np.nan, 300.0] + [800.0] * (len(points) - 1) + [1500.0]
        segs += [seg] * (len(points) + 3)
    return Toolpath(
        tip=np.array(tips), axis=np.array(axes), feed=np.array(feeds),
        kind=np.array(kinds, dtype=np.int8), segment=np.array(segs, dtype=np.int32),
        name="rough 3+2 (UMR 1-2)", tool_number=1, cutter=Cutter(6.0, 3.0, 30.0),
        spindle_rpm=12000.0, coolant=True,
    )


def finishing_spiral(n: int = 60, turns_deg: float = 400.0) -> Toolpath:
    """A simultaneous 5-axis pass whose axis passes through +Z (A = 0) while C turns
    ``turns_deg`` degrees: the tilt goes from -20 to +20 degrees."""
    s = np.linspace(0.0, 1.0, n)
    phi = np.radians(turns_deg) * s
    tilt = np.radians(-20.0 + 40.0 * s)
    axis = np.stack([np.sin(tilt) * np.sin(phi), np.sin(tilt) * np.cos(phi), np.cos(tilt)], 1)
    radius = 28.0 + 4.0 * s
    tip = np.stack([radius * np.cos(phi), radius * np.sin(phi), 18.0 + 8.0 * s], 1)
    approach = tip[0] + 12.0 * axis[0]
    leave = tip[-1] + 12.0 * axis[-1]
    tips = np.vstack([approach, tip, leave])
    axes = np.vstack([axis[0], axis, axis[-1]])
    kinds = np.array([MoveKind.RAPID, MoveKind.PLUNGE] + [MoveKind.FEED] * (n - 1)
                     + [MoveKind.RETRACT], dtype=np.int8)
    feeds = np.array([np.nan, 400.0] + [1000.0] * (n - 1) + [2000.0])
    return Toolpath(
        tip=tips, axis=axes, feed=feeds, kind=kinds, name="finish 5-axis spiral",
        tool_number=2, cutter=Cutter(4.0, 2.0, 20.0), spindle_rpm=15000.0, coolant=True,
    )


def over_travel() -> Toolpath:
    """Three poses; the last needs a tilt of 110 degrees (xyzac-trt sim: -100..50)."""
    axes = np.array([tilted_axis(10.0, 0.0), tilted_axis(40.0, 0.0), tilted_axis(110.0, 0.0)])
    tips = np.array([[0.0, 0.0, 30.0], [5.0, 0.0, 25.0], [10.0, 0.0, 20.0]])
    return Toolpath(
        tip=tips, axis=axes, feed=np.array([np.nan, 500.0, 500.0]),
        kind=np.array([MoveKind.RAPID, MoveKind.FEED, MoveKind.FEED], dtype=np.int8),
        name="over-travel", tool_number=1, cutter=Cutter(6.0, 3.0, 30.0),
    )


def write_fixtures() -> None:
    """Rewrite fixtures/apt/post_*.apt from the functions above."""
    from postproc.apt import write_apt

    write_apt(FIXTURES / "post_impeller_ops.apt", [roughing_3p2(), finishing_spiral()],
              header="impeller-cam post-processor test path: 3+2 roughing and a 5-axis "
              "spiral through A = 0 turning C by 400 deg (xyzac-trt sim)")
    write_apt(FIXTURES / "post_overtravel.apt", [over_travel()],
              header="impeller-cam post-processor test path: the third GOTO needs A = 110 deg")


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    write_fixtures()
