"""Tapered flutes: one tool model for the outline, collision meshes, verifier and flank.

The library's flank cutter ``ball6_flank3`` (R 3 ball, 3 deg per side over 45 mm of
flutes): its cone is tangent to the ball at ``R (1 - sin a)``, its radius there is
``R cos a`` and ``r0 + 45 tan a`` at the top of the flutes. Every consumer of the tool
(``Tool.radius_at``, ``tool_mesh.cutter_profile``, ``toolshape.tool_shape``,
``FlankTool``) must give that same outline.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.collision.tool_mesh import cutter_profile
from cam.finishing.flank_tool import FlankTool
from cam.tools import Tool, resolve_tool
from cam.verify.toolshape import tool_shape

FLANK = resolve_tool("ball6_flank3")


def _tool(shape: str, radius: float, corner: float, taper: float, flute: float) -> Tool:
    return Tool(name="t", number=1, shape=shape, diameter=2 * radius, corner_radius=corner,
                flute_length=flute, shank_diameter=4 * radius, stickout=flute + 10,
                flute_taper_deg=taper)


def _primitive_radius(rows: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Largest radius of the union of ``toolshape`` primitives at heights z, mm."""
    out = np.zeros_like(z)
    for alpha, beta, gamma, zlo, zhi, _ in rows:
        inside = (z >= zlo - 1e-12) & (z <= zhi + 1e-12)
        r2 = -(alpha * z * z + beta * z + gamma)
        out = np.where(inside, np.maximum(out, np.sqrt(np.maximum(r2, 0.0))), out)
    return out


def test_library_flank_cutter_closed_form() -> None:
    a = math.radians(3.0)
    assert FLANK.flute_taper_deg == 3.0 and FLANK.radius == 3.0
    assert FLANK.flank_start == pytest.approx(3.0 * (1 - math.sin(a)), abs=1e-12)
    assert FLANK.flank_r0 == pytest.approx(3.0 / math.cos(a) - 3.0 * math.tan(a), abs=1e-12)
    top = 3.0 / math.cos(a) - 3.0 * math.tan(a) + 45.0 * math.tan(a)
    assert FLANK.flute_top_radius == pytest.approx(top, abs=1e-12)
    # the outline: the ball below the tangent point, the cone above, continuous there
    h = np.array([0.0, 1.0, FLANK.flank_start, 10.0, 45.0])
    expected = [0.0, math.sqrt(9 - 4), 3 * math.cos(a), FLANK.flank_r0 + 10 * math.tan(a), top]
    assert FLANK.radius_at(h) == pytest.approx(expected, abs=1e-12)
    # the neck starts at the flutes' top radius and grows at 3 deg to the 12 mm shank
    neck = FLANK.shank_segments()[0]
    assert neck.z0 == 45.0 and neck.r0 == pytest.approx(top, abs=1e-12)
    assert neck.r1 == pytest.approx(6.0, abs=1e-12)
    outline = FLANK.outline()
    assert np.all(np.diff(outline[:, 1]) >= -1e-12)


@settings(max_examples=25, deadline=None)
@given(shape=st.sampled_from(["ball", "flat", "bullnose"]), radius=st.floats(1.0, 6.0),
       taper=st.floats(0.0, 10.0), flute=st.floats(13.0, 50.0))
def test_every_consumer_gives_the_same_outline(shape: str, radius: float, taper: float,
                                               flute: float) -> None:
    corner = {"ball": radius, "flat": 0.0}.get(shape, 0.4 * radius)
    tool = _tool(shape, radius, corner, taper, flute)
    z = np.linspace(1e-3, flute - 1e-3, 157)
    true = tool.radius_at(z)
    flank = FlankTool.from_tool(tool)
    tip, axis = np.zeros(3), np.array([0.0, 0.0, 1.0])
    # the verifier's primitives: exact for ball and flat, within the sagitta for a corner
    # (measured normal to the outline by the flank view's exact distance)
    shape_rows = tool_shape(tool)
    got = _primitive_radius(shape_rows.cutter, z)
    gap = flank.signed_distance(np.column_stack([got, 0 * z, z]), tip, axis)
    assert np.abs(gap).max() <= shape_rows.profile_error + 1e-9
    if shape != "bullnose":
        assert np.allclose(got, true, atol=1e-9)
    # the collision profile: circumscribes, within its arc excess (radially, over the arc)
    profile, excess = cutter_profile(tool)
    side = profile[1:-1]
    mesh_r = np.interp(z, side[:, 1], side[:, 0])
    assert np.all(mesh_r >= true - 1e-9)
    above = z >= tool.flank_start + 1e-6
    assert np.allclose(mesh_r[above], true[above], atol=1e-9)  # the cone line is exact
    # the flank view: points on the outline are at distance 0
    pts = np.column_stack([true, np.zeros_like(z), z])
    d = flank.signed_distance(pts, tip, axis)
    assert np.abs(d).max() < 1e-9
    assert excess >= 0.0


def test_tapered_ball_cutter_offset_is_the_cone_moved_out() -> None:
    """A grown cutter (allowance) is the cone moved out by the offset, normal to it."""
    a = FLANK.flute_half_angle
    for offset in (-0.5, 0.3):
        profile, _ = cutter_profile(FLANK, offset)
        side = profile[1:-1]
        z = np.array([10.0, 30.0, 45.0])
        r = np.interp(z, side[:, 1], side[:, 0])
        assert r == pytest.approx(FLANK.flank_radius_at(z) + offset / math.cos(a), abs=1e-9)


def test_flank_view_reads_the_tool() -> None:
    flank = FlankTool.from_tool(FLANK)
    assert flank.half_angle == pytest.approx(math.radians(3.0))
    assert flank.ball_radius == 3.0 and flank.flute_length == 45.0
    assert flank.r0 == FLANK.flank_r0 and flank.h_lo == FLANK.flank_start
    # a tapered ball and a cylindrical one differ by the taper only
    cylinder = FlankTool.from_tool(resolve_tool("ball6_taper"))
    assert cylinder.half_angle == 0.0 and cylinder.r0 == 3.0


@pytest.mark.parametrize("pitch", [0.1, 0.05])
def test_verifier_sweeps_the_taper_a_flank_cut_wall_is_exact(pitch: float) -> None:
    """A tapered ball leaning by its taper angle has a vertical flank line; swept along
    Y through a box it leaves a vertical wall at ``x = R (1 - sin a)`` exactly (a
    cylinder model of the flutes would leave a wall leaning by ``a``)."""
    from cam.verify.stock import Stock

    r, a = 2.0, math.radians(3.0)
    tool = _tool("ball", r, r, 3.0, 20.0)
    stock = Stock.box([-8.0, -8.0, -10.0], [8.0, 8.0, 0.0], pitch)
    axis = np.array([-math.sin(a), 0.0, math.cos(a)])
    tips = np.array([[0.0, -12.0, -8.0]])
    stock.sweep(tips, np.array([[0.0, 24.0, 0.0]]), axis[None, :], np.array([0], np.int32),
                tool_shape(tool))
    points, _, made = stock.surface_samples()
    wall = (made == 0) & (np.abs(points[:, 1]) < 5) & (points[:, 2] > -5.5) \
        & (points[:, 2] < -0.5) & (points[:, 0] > 0) & (points[:, 0] < 4)
    assert wall.sum() > 100
    assert np.abs(points[wall, 0] - r * (1 - math.sin(a))).max() < 1e-9
