"""Blade points left to the edge passes (cam/finishing/edge_cover.py, issue 23).

Closed form: a ball of radius R along a straight pass at height R above a plane leaves
``sqrt(d**2 + R**2) - R`` at lateral distance d, so a plane point is finished to the
scallop h exactly when ``d <= sqrt((R + h)**2 - R**2)``. The trim: with a cover, a
blade point pass keeps nothing the cover finishes except the overlap it needs for
what it still cuts, and never more than without it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.finishing.edge_cover import EdgeCover
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.passes import passage_paths
from cam.finishing.swarf_plan import point_passes_left, swarf_walls
from cam.tools import load_tool_library
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("radius", "scallop"), [(3.0, 0.01), (2.0, 0.1), (5.0, 0.002)])
def test_a_straight_pass_covers_the_strip_of_its_scallop(radius: float, scallop: float) -> None:
    x = np.linspace(-10.0, 10.0, 7)  # 3.3 mm apart: densified to 0.02 mm
    cover = EdgeCover([np.c_[x, np.zeros_like(x), np.full_like(x, radius)]], radius, scallop)
    def strip(height: float) -> float:  # lateral distance where the ball leaves height
        return math.sqrt((radius + height) ** 2 - radius**2)

    # 5e-5 mm of material either side of the scallop: above the densified centres'
    # error, 0.02**2 / (8 R) <= 2.5e-5 mm
    width, inner, outer = strip(scallop), strip(scallop - 5e-5), strip(scallop + 5e-5)
    d = np.array([0.0, 0.5 * width, inner, outer, 2.0 * width, 5.0 * radius])
    along = np.array([0.0, 0.01, 3.0, -4.99, 7.3, 0.0])  # on samples and between
    centre = np.c_[along, d, np.full_like(d, radius)]
    normal = np.tile([0.0, 0.0, 1.0], (len(d), 1))
    np.testing.assert_array_equal(cover(centre, normal), [True, True, True, False, False, False])
    # beyond the pass's end the ball's cap only
    beyond = np.array([[10.0 + inner, 0.0, radius], [10.0 + outer, 0.0, radius]])
    np.testing.assert_array_equal(cover(beyond, normal[:2]), [True, False])
    assert not EdgeCover([], radius, scallop)(centre, normal).any()


def test_covered_points_are_left_to_the_cover() -> None:
    """On ``straight`` with its middle rulings swarf-cut: the points a cover finishes
    (here the blade points within 3 mm of either edge end, along the pass) are not
    kept unless within the end overlap of a point the pass still cuts, and no point
    is kept that was not kept without the cover."""
    from tests.cam.test_finishing_swarf_plan import _arc, _middle_cut

    surfaces = build_surfaces(load_spec(ROOT / "fixtures" / "impellers" / "straight"
                                        / "spec.toml"))
    tool = load_tool_library(ROOT / "fixtures" / "tools" / "library.toml")["ball4_taper"]
    walls = [_middle_cut(sw) for sw in swarf_walls(surfaces, tool, FinishOptions())]
    stepover = scallop_stepover(tool.radius, 0.1)
    end = stepover + 1.0
    base = passage_paths(surfaces, tool.radius, 1.0, stepover, blade=True, hub=False,
                         reach=tool.flute_length - tool.radius)
    blade = [p for p in base if p.operation == "blade"]
    near_end = {}
    for p in blade:
        arc = _arc(p.centre)
        near_end[id(p.centre)] = (arc < 3.0) | (arc > arc[-1] - 3.0)

    def covered(centre: np.ndarray, normal: np.ndarray) -> np.ndarray:
        return near_end[id(centre)]

    plain = point_passes_left(walls, stepover, end)
    trimmed = point_passes_left(walls, stepover, end, covered)
    dropped = 0
    for p in blade:
        before, after = plain(p), trimmed(p)
        before = np.ones(len(p), bool) if before is None else before
        after = np.ones(len(p), bool) if after is None else after
        assert not (after & ~before).any()
        sw = next(w for w in walls if p.wall is not None and w.wall.label == p.wall.label)
        assert p.wall is not None and p.blade_v is not None
        cut = ~sw.inside(p.wall.own_u(p.curve_u), p.blade_v, stepover) & ~near_end[id(p.centre)]
        arc = _arc(p.centre)
        reach = (np.abs(arc[:, None] - arc[None, cut]).min(axis=1) if cut.any()
                 else np.full(len(p), np.inf))
        np.testing.assert_array_equal(after, reach <= end)
        dropped += int((before & ~after).sum())
    assert dropped > 0


def test_the_neighbours_edges_count_only_when_every_passage_is_machined() -> None:
    from dataclasses import replace

    from cam.finishing.edge_cover import edge_cover_turns

    options = FinishOptions()
    assert edge_cover_turns(replace(options, passages=None), 9) == (-1, 0, 1)
    assert edge_cover_turns(replace(options, passages=9), 9) == (-1, 0, 1)
    assert edge_cover_turns(replace(options, passages=8), 9) == (0,)
    assert edge_cover_turns(replace(options, passages=1), 9) == (0,)
