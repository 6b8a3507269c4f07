"""Swarf passes on the blade sides of the developable fixture ``straight`` (issue 23).

Its blades have rulings parallel to the impeller axis (flat hub, flat tip, equal wrap
on both lines): the sides are general cylinders, so a cylindrical flank laid along a
ruling touches the whole ruling. Acceptance: the whole band between the blade tip and
the fillet is swarf-cut within overcut 0.01 mm and undercut 0.03 mm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cam.finishing.flank_tool import FlankTool
from cam.finishing.swarf_blade import plan_blade_side, side_segment
from cam.tools import load_tool_library
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def straight() -> ImpellerSurfaces:
    return build_surfaces(load_spec(ROOT / "fixtures" / "impellers" / "straight" / "spec.toml"))


@pytest.fixture(scope="module")
def tool() -> FlankTool:
    return FlankTool.from_tool(load_tool_library(ROOT / "fixtures" / "tools" /
                                                 "library.toml")["ball4_taper"])


def test_straight_fixture_rulings_are_axial(straight: ImpellerSurfaces) -> None:
    u = np.linspace(0.0, 1.0, 9)
    for blade in straight.blades:
        ruling = blade.ruling(u)
        assert np.allclose(np.abs(ruling[:, 2]), 1.0, atol=1e-9)


@pytest.mark.parametrize("role", ["pressure", "suction"])
def test_straight_fixture_swarf_cut_within_tolerance(straight: ImpellerSurfaces,
                                                     tool: FlankTool, role: str) -> None:
    spec = straight.spec
    result = plan_blade_side(straight.blades[0], straight.hub, role, tool,
                             leading_edge=spec.leading_edge, trailing_edge=spec.trailing_edge,
                             fillet_radius=spec.fillet_radius, ruling_step_mm=1.0,
                             overcut=0.01, undercut=0.03)
    post = result.postures
    # developable: the tool touches every ruling (exact to rounding)
    assert np.abs(post.deviation_min).max() < 1e-6
    assert np.abs(post.deviation_max).max() < 1e-6
    # the moving tool: the chord between rulings only (sagitta step^2 / (8 R_curvature))
    assert result.sweep.overcut <= 0.01
    assert result.sweep.undercut <= 0.03
    assert result.cuttable.all()
    # the band: from the tip down to the ball's clearance above the hub (flat hub at z = 0:
    # the ball centre R_b = 2 mm above it, the flank from there: 6 of the 8 mm span)
    seg = side_segment(straight.blades[0], role, spec.leading_edge, spec.trailing_edge)
    bottom = seg.point(post.u, result.v_bottom)
    assert np.allclose(bottom[:, 2], tool.ball_radius, atol=1e-6)
    assert result.area_share == pytest.approx(0.75, abs=1e-3)
    # the ball clears the hub, the rulings stay within the flutes
    assert np.all(post.tips[:, 2] >= -1e-6)
    assert np.all(post.top_height <= tool.flute_length + 1e-6)


def test_tolerances_are_settable(straight: ImpellerSurfaces, tool: FlankTool) -> None:
    """A tolerance below the chord error of the moving tool rejects those rulings."""
    spec = straight.spec
    result = plan_blade_side(straight.blades[0], straight.hub, "pressure", tool,
                             leading_edge=spec.leading_edge, trailing_edge=spec.trailing_edge,
                             fillet_radius=spec.fillet_radius, ruling_step_mm=2.0,
                             overcut=1e-4, undercut=0.03, refine=False)
    assert result.sweep.overcut > 1e-4
    assert not result.cuttable.all()
    assert result.area_share < 0.75


@pytest.mark.slow
def test_fitted_postures_keep_the_ball_off_the_hub() -> None:
    """nine_blade's suction side with ``ball6_flank3``: the least-squares fit moved the
    ball up to 0.15 mm nearer the hub than the tangent-plane posture the band bottom was
    found with (the solid scene then saw the cutter in the hub at 60 rulings); the band
    bottom is raised there until every fitted ball centre keeps ``max(R_b, r_f)``."""
    spec = load_spec(ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml")
    surfaces = build_surfaces(spec)
    flank = FlankTool.from_tool(load_tool_library(ROOT / "fixtures" / "tools" /
                                                  "library.toml")["ball6_flank3"])
    blade = surfaces.blades[1]
    result = plan_blade_side(blade, surfaces.hub, "suction", flank,
                             leading_edge=spec.leading_edge, trailing_edge=spec.trailing_edge,
                             fillet_radius=float(spec.fillet_radius), ruling_step_mm=4.0)
    post = result.postures
    need = max(flank.ball_radius, float(spec.fillet_radius))
    gap = surfaces.hub.signed_distance(post.tips + flank.ball_radius * post.axes) - need
    assert gap.min() >= -1e-9
    assert np.any(result.v_bottom < 0.6)  # the band still reaches below mid-span
