"""Swarf (flank) postures and deviations on closed-form ruled surfaces (issue 23).

Developable patches (a cylinder, a cone) are touched along every ruling by a tool laid
on the tangent plane: the predicted deviation is 0 within 1 um. A hyperbolic
paraboloid (twisted, not developable) is not: its deviation follows the twist, and
the least-squares refinement lowers the largest deviation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.finishing.flank_tool import FlankTool
from cam.finishing.swarf import RuledPatch, plan_postures
from cam.finishing.swarf_sweep import swept_deviation

Array = np.ndarray


def cylinder_patch(radius: float, height: float, span: float, outside: bool) -> RuledPatch:
    """Circular cylinder about +Z, theta in [0, span], z from height (v=0) to 0 (v=1)."""
    sign = 1.0 if outside else -1.0

    def point(u: Array, v: Array) -> Array:
        t = span * np.asarray(u)
        return np.stack(np.broadcast_arrays(radius * np.cos(t), radius * np.sin(t),
                                            height * (1 - np.asarray(v))), axis=-1)

    def normal(u: Array, v: Array) -> Array:
        t = span * np.asarray(u) + 0 * np.asarray(v)
        return sign * np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=-1)

    return RuledPatch(point, normal)


def cone_patch(half_angle: float, rho_top: float, rho_bottom: float, span: float) -> RuledPatch:
    """Cone with apex at the origin opening downwards (-Z), convex side outwards."""
    sb, cb = math.sin(half_angle), math.cos(half_angle)

    def point(u: Array, v: Array) -> Array:
        t = span * np.asarray(u)
        rho = rho_top + (rho_bottom - rho_top) * np.asarray(v)
        return np.stack(np.broadcast_arrays(rho * sb * np.cos(t), rho * sb * np.sin(t),
                                            -rho * cb), axis=-1)

    def normal(u: Array, v: Array) -> Array:
        t = span * np.asarray(u) + 0 * np.asarray(v)
        return np.stack([cb * np.cos(t), cb * np.sin(t), sb + 0 * t], axis=-1)

    return RuledPatch(point, normal)


def twisted_patch(twist: float, width: float, height: float) -> RuledPatch:
    """Hyperbolic paraboloid y = twist u v: rulings from (x, 0, h) to (x, twist u, 0)."""

    def point(u: Array, v: Array) -> Array:
        x = width * np.asarray(u)
        v = np.asarray(v)
        return np.stack(np.broadcast_arrays(x, twist * x * v / width, height * (1 - v)), axis=-1)

    def normal(u: Array, v: Array) -> Array:
        h = 1e-6
        du = point(u + h, v) - point(u - h, v)
        dv = point(u, v + h) - point(u, v - h)
        n = np.cross(du, dv)
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        return -n if n.reshape(-1, 3)[0, 1] < 0 else n

    return RuledPatch(point, normal)


U = np.linspace(0.0, 1.0, 41)


@pytest.mark.parametrize("outside", [True, False])
def test_cylinder_patch_flank_milled_exactly(outside: bool) -> None:
    patch = cylinder_patch(30.0, 20.0, 0.8, outside)
    tool = FlankTool.flat(5.0, 30.0)
    post = plan_postures(patch, tool, U)
    assert np.abs(post.deviation_min).max() < 1e-6
    assert np.abs(post.deviation_max).max() < 1e-6
    sweep = swept_deviation(patch, tool, post, refine=1)
    assert sweep.overcut < 1e-6
    assert np.abs(sweep.deviation).max() < 1e-6  # every sample lies on its own ruling
    # the tool axis is the ruling (a cylinder): parallel to Z
    assert np.allclose(np.abs(post.axes[:, 2]), 1.0, atol=1e-9)


@pytest.mark.parametrize("taper_deg", [1.5, 3.0, 6.0])
def test_cone_patch_flank_milled_exactly_by_a_tapered_ball(taper_deg: float) -> None:
    patch = cone_patch(math.radians(25.0), 20.0, 45.0, 0.9)
    tool = FlankTool.tapered_ball(2.0, taper_deg, 40.0)
    post = plan_postures(patch, tool, U)
    dev = np.concatenate([post.deviation_min, post.deviation_max])
    assert np.abs(dev).max() < 1e-6
    sweep = swept_deviation(patch, tool, post, refine=1)
    assert np.abs(sweep.deviation).max() < 1e-6
    # the tool's flank bottom sits at the ruling's bottom end, the top within the flutes
    assert np.all(post.top_height <= tool.flute_length)
    # the axis leans from the ruling by the taper angle
    chord = patch.point(U, np.zeros_like(U)) - patch.point(U, np.ones_like(U))
    chord /= np.linalg.norm(chord, axis=1, keepdims=True)
    lean = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", chord, post.axes), -1, 1)))
    assert np.allclose(lean, taper_deg, atol=1e-6)


def test_cone_deviation_between_postures_is_the_chord_sagitta() -> None:
    """Blended postures cut the chord between rulings: overcut = sagitta R dt^2 / 8."""
    beta = math.radians(25.0)
    patch = cone_patch(beta, 20.0, 45.0, 0.9)
    tool = FlankTool.tapered_ball(2.0, 3.0, 40.0)
    post = plan_postures(patch, tool, U)
    sweep = swept_deviation(patch, tool, post, refine=4)
    step = 0.9 / (len(U) - 1)
    sagitta = 45.0 * math.sin(beta) * step**2 / 8  # largest section radius: the bottom
    assert sweep.overcut == pytest.approx(sagitta, rel=0.05)
    assert sweep.undercut < 1e-6


def test_flank_signed_distance_closed_form() -> None:
    """Points on, inside and outside a tapered ball: distances from the (h, rho) profile."""
    tool = FlankTool.tapered_ball(2.0, 5.0, 20.0)
    a = math.radians(5.0)
    tip, axis = np.zeros(3), np.array([0.0, 0.0, 1.0])
    h = np.array([5.0, 10.0, 15.0])
    r = tool.radius_at(h)
    for offset in (-0.3, 0.0, 0.4):
        # move perpendicular to the flank line in the (h, rho) plane
        pts = np.stack([r + offset * math.cos(a), 0 * h, h - offset * math.sin(a)], axis=1)
        assert np.allclose(tool.signed_distance(pts, tip, axis), offset, atol=1e-12)
    # the ball: below the flank
    pts = np.array([[0.0, 0.0, -0.5], [1.0, 0.0, 2.0 - math.sqrt(3.0)], [0.0, 0.5, 1.0]])
    assert np.allclose(tool.signed_distance(pts, tip, axis), [0.5, 0.0, math.hypot(0.5, 1) - 2])


def test_twisted_patch_deviates_and_refinement_helps() -> None:
    patch = twisted_patch(4.0, 40.0, 20.0)
    tool = FlankTool.tapered_ball(4.0, 0.0, 30.0)
    u = np.linspace(0.0, 1.0, 11)
    plain = plan_postures(patch, tool, u, refine=False)
    fitted = plan_postures(patch, tool, u, overcut=0.0, undercut=0.0)
    spread_plain = np.maximum(-plain.deviation_min, plain.deviation_max)
    spread_fit = np.maximum(-fitted.deviation_min, fitted.deviation_max)
    # a cylinder along a twisted ruling cuts beside it: about R phi^2 / 2 with phi the
    # turn of the normal over half the ruling (here 0.05 rad: 0.005 mm)
    assert 0.003 < spread_plain.max() < 0.006
    assert np.all(spread_fit <= spread_plain + 1e-9)
    assert spread_fit.max() < 0.1 * spread_plain.max()
    swept_plain = swept_deviation(patch, tool, plain)
    swept_fit = swept_deviation(patch, tool, fitted)
    assert swept_plain.overcut > 0.003
    assert max(swept_fit.overcut, swept_fit.undercut) < 0.5 * swept_plain.overcut


@settings(max_examples=15, deadline=None)
@given(radius=st.floats(10.0, 80.0), tool_r=st.floats(1.0, 8.0),
       taper=st.floats(0.0, 10.0), outside=st.booleans())
def test_developable_cylinder_any_tool(radius: float, tool_r: float, taper: float,
                                      outside: bool) -> None:
    """A tool of any taper laid on a cylinder's tangent plane touches the whole ruling."""
    if not outside and tool_r > 0.5 * radius:
        return
    patch = cylinder_patch(radius, 15.0, 0.5, outside)
    tool = FlankTool.tapered_ball(tool_r, taper, 40.0)
    post = plan_postures(patch, tool, np.linspace(0, 1, 9), samples=11, refine=False)
    assert np.abs(post.deviation_min).max() < 1e-6
    assert np.abs(post.deviation_max).max() < 1e-6


def test_pass_deviation_of_a_cylinder_pass_is_exact() -> None:
    """A pass over part of a cylinder patch, its planned postures only: zero everywhere
    between its end rulings (the flat flank lies along each ruling)."""
    from cam.finishing.swarf_sweep import pass_deviation

    patch = cylinder_patch(30.0, 20.0, 0.8, True)
    tool = FlankTool.flat(5.0, 30.0)
    post = plan_postures(patch, tool, U)
    field = pass_deviation(patch.point, tool, post, np.arange(10, 25), refine=1)
    assert field.u[0] == U[10] and field.u[-1] == U[24]
    assert np.abs(field.deviation).max() < 1e-6


def test_pass_deviation_bounds_the_section_strip_minimum() -> None:
    """On the twisted patch the point-wise field is nowhere below the strip minimum
    (which also looks beside the ruling) and shows the material the strip hides."""
    from cam.finishing.swarf_sweep import pass_deviation

    patch = twisted_patch(4.0, 40.0, 20.0)
    tool = FlankTool.tapered_ball(4.0, 0.0, 30.0)
    u = np.linspace(0.0, 1.0, 21)
    post = plan_postures(patch, tool, u)
    strip = swept_deviation(patch, tool, post, refine=8, window=16)
    field = pass_deviation(patch.point, tool, post, np.arange(21), refine=8, window=16)
    np.testing.assert_array_equal(field.u, strip.u)
    assert np.all(field.deviation >= strip.deviation - 1e-12)
    assert field.undercut > 10 * strip.undercut
