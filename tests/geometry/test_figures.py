"""Derived figures: eq. (1), d_min closed forms, rule deviation, clearance checks."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from geometry.design import DesignParameters, generate, load_design
from geometry.figures import (
    check_clearances,
    closest_points,
    compute_figures,
    facing_sides,
    max_ball_radius,
    minimum_passage_width,
    rule_deviation,
)
from geometry.outline import blade_outline
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.errors import InputError
from tests.geometry.test_design import cylinder_params

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "impellers"
HUB_R, SHROUD_R = 20.0, 40.0


def radial_blades(**changes: Any) -> DesignParameters:
    """Flat radial blades (planes through the axis) between cylinders r = 20 and r = 40."""
    base = {"name": "radial", "camber_points": 11, "contour_points": 11}
    return cylinder_params(**{**base, **changes})


def surfaces_of(params: DesignParameters, source: Path | None = None) -> ImpellerSurfaces:
    return build_surfaces(generate(params).to_spec(source))


def face_chord(radius: float, thickness: float, angle: float) -> float:
    """Distance between the facing sides of two flat radial blades ``angle`` apart at
    ``radius``: the side points sit at radius sqrt(R^2 + d^2/4), turned by
    alpha = atan(d / 2R) towards each other."""
    rho = math.hypot(radius, thickness / 2)
    alpha = math.atan2(thickness / 2, radius)
    return 2 * rho * math.sin((angle - 2 * alpha) / 2)


# --- M4 eq. (1) ----------------------------------------------------------------------
def test_eq1_hand_computed() -> None:
    # r_max = (d_min - 2 eta) / (2 k)
    assert max_ball_radius(13.0, 0.5, 1.2) == pytest.approx(5.0, abs=1e-15)
    assert max_ball_radius(14.0, 0.5, 1.2) == pytest.approx(13.0 / 2.4, abs=1e-15)
    assert max_ball_radius(20.0, 1.0, 1.5) == pytest.approx(6.0, abs=1e-15)
    assert max_ball_radius(1.0, 1.0) < 0  # no ball fits: reported, not clamped


@pytest.mark.parametrize(("k", "eta", "field"), [(0.9, 0.5, "k"), (1.2, -0.1, "eta")])
def test_eq1_rejects_bad_factors(k: float, eta: float, field: str) -> None:
    with pytest.raises(InputError) as error:
        max_ball_radius(14.0, eta, k)
    assert error.value.field == field


# --- closest points --------------------------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(
    gap=st.floats(0.1, 5.0),
    apex_u=st.floats(0.05, 0.95),
    apex_v=st.floats(0.05, 0.95),
    curvature=st.floats(0.5, 20.0),
)
def test_closest_points_plane_and_paraboloid(
    gap: float, apex_u: float, apex_v: float, curvature: float
) -> None:
    # plane z = 0 and the paraboloid z = gap + c |(u, v) - apex|^2 over the unit square:
    # closest at the apex, distance = gap
    def plane(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.stack([u, v, np.zeros_like(u + v)], axis=-1)

    def bowl(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        z = gap + curvature * ((u - apex_u) ** 2 + (v - apex_v) ** 2)
        return np.stack([u + 0 * v, v + 0 * u, z], axis=-1)

    pair = closest_points(plane, bowl, grid=(11, 11))
    assert pair is not None
    assert pair.distance == pytest.approx(gap, abs=1e-7)
    np.testing.assert_allclose(pair.points[1], [apex_u, apex_v, gap], atol=1e-4)
    np.testing.assert_allclose(pair.points[0], [apex_u, apex_v, 0.0], atol=1e-4)


# --- d_min closed forms ------------------------------------------------------------------
@pytest.mark.parametrize(("blades", "thickness"), [(6, 2.0), (9, 2.5), (12, 1.0)])
def test_d_min_of_flat_radial_blades_is_the_chord_at_the_hub(blades: int, thickness: float) -> None:
    surfaces = surfaces_of(radial_blades(blades=blades, thickness_mm=(thickness, thickness)))
    figures = compute_figures(surfaces)
    pitch = 2 * math.pi / blades
    expected = face_chord(HUB_R, thickness, pitch)
    assert figures.d_min == pytest.approx(expected, abs=1e-6)
    # where: both points at the hub edge of the sides, at angles alpha and pitch - alpha
    rho = math.hypot(HUB_R, thickness / 2)
    alpha = math.atan2(thickness / 2, HUB_R)
    radii = np.hypot(figures.d_min_points[:, 0], figures.d_min_points[:, 1])
    angles = np.arctan2(figures.d_min_points[:, 1], figures.d_min_points[:, 0])
    np.testing.assert_allclose(radii, rho, atol=1e-5)
    np.testing.assert_allclose(angles, [alpha, pitch - alpha], atol=1e-6)
    assert figures.blades == blades and figures.splitters == 0
    assert figures.min_thickness == pytest.approx(thickness)
    # max fillet: half the hub-edge width (blades normal to the hub), below the blade height
    assert figures.max_fillet_radius == pytest.approx(expected / 2, abs=1e-6)
    assert figures.r_max == pytest.approx((expected - 2 * 0.5) / 2.4, abs=1e-6)


def test_d_min_with_splitters_is_main_to_splitter_chord() -> None:
    surfaces = surfaces_of(radial_blades(blades=4, splitters=1, splitter_start=0.4))
    figures = compute_figures(surfaces)
    expected = face_chord(HUB_R, 2.0, math.pi / 4)  # splitter half a pitch away
    assert figures.d_min == pytest.approx(expected, abs=1e-6)
    assert "splitter" in figures.d_min_pair
    assert figures.splitters == 4
    # the splitter starts at u = 0.4: its points lie downstream (z <= 60 - 0.4 * 50)
    assert min(figures.d_min_points[:, 2]) <= 40.0 + 1e-6


def test_d_min_restricted_to_the_hub_edge() -> None:
    surfaces = surfaces_of(radial_blades())
    width = minimum_passage_width(surfaces, v_range=(1.0, 1.0))
    assert width.distance == pytest.approx(face_chord(HUB_R, 2.0, math.pi / 3), abs=1e-6)
    np.testing.assert_allclose(width.pair.params[:, 1], 1.0)
    assert width.sides.label == "main pressure / main suction"


@pytest.mark.parametrize("name", ["splitter", "small"])
def test_d_min_agrees_with_brute_force_grid(name: str) -> None:
    surfaces = build_surfaces(load_spec(FIXTURES / name / "spec.toml"))
    width = minimum_passage_width(surfaces)
    u, v = np.meshgrid(np.linspace(0, 1, 101), np.linspace(0, 1, 26), indexing="ij")
    spec, blades = surfaces.spec, surfaces.all_blades()
    brute = math.inf
    for f in facing_sides(surfaces):
        # every face of the two blades' outlines except the ones turned away
        faces = [
            np.concatenate([x.point(u, v).reshape(-1, 3) for x in outline if x.role != turned_away])
            for outline, turned_away in (
                (
                    blade_outline(blades[f.index_a], spec.leading_edge, spec.trailing_edge),
                    "suction",
                ),
                (
                    blade_outline(blades[f.index_b], spec.leading_edge, spec.trailing_edge),
                    "pressure",
                ),
            )
        ]
        brute = min(brute, float(cKDTree(faces[1]).query(faces[0])[0].min()))
    # the local solve must not be worse than a dense grid, and a dense grid is close
    assert width.distance <= brute + 1e-9
    assert brute - width.distance < 0.05


# --- rule deviation ----------------------------------------------------------------------
def test_rule_deviation_is_zero_for_ruled_blades() -> None:
    surfaces = build_surfaces(load_spec(FIXTURES / "small" / "spec.toml"))
    deviation, _ = rule_deviation(surfaces)
    assert deviation < 1e-9


@pytest.mark.parametrize("offset_deg", [2.0, 5.0, -8.0])
def test_rule_deviation_closed_form_for_the_midspan_case(offset_deg: float) -> None:
    # radial flat blade; the mid-span line (radius 30) is turned by offset * u about +Z, so
    # R(u, 1/2) = (30 cos(offset u), 30 sin(offset u), z): its distance from the ruled plane
    # y = 0 is 30 |sin(offset u)|, largest at the trailing edge u = 1.
    offset = math.radians(offset_deg)
    surfaces = surfaces_of(radial_blades(midspan_wrap_offset=offset))
    deviation, where = rule_deviation(surfaces)
    expected = 0.5 * (HUB_R + SHROUD_R) * abs(math.sin(offset))
    assert deviation == pytest.approx(expected, abs=1e-6)
    np.testing.assert_allclose(where, [1.0, 0.5], atol=1e-3)
    if offset_deg == 5.0:  # the figures report the same number
        assert compute_figures(surfaces).rule_deviation == pytest.approx(expected, abs=1e-6)


def test_rule_deviation_grows_with_the_midspan_offset() -> None:
    params = load_design(FIXTURES / "small" / "design.toml")
    values = [
        rule_deviation(surfaces_of(dataclasses.replace(params, midspan_wrap_offset=a)))[0]
        for a in np.radians([1.0, 2.0, 4.0])
    ]
    assert 0 < values[0] < values[1] < values[2]


# --- clearance checks ------------------------------------------------------------------
def test_blades_that_touch_are_an_input_error() -> None:
    # 24 blades, 15 deg apart: the faces meet at the hub when d >= 2 R tan(7.5 deg) = 5.27 mm
    source = Path("touching/spec.toml")
    surfaces = surfaces_of(radial_blades(blades=24, thickness_mm=(6.0, 6.0)), source)
    with pytest.raises(InputError) as error:
        check_clearances(surfaces)
    assert error.value.file == str(source)
    assert error.value.field == "blade.thickness_mm"
    assert error.value.value == 6.0
    assert "touch" in error.value.message
    # just below the limit it passes
    ok = surfaces_of(radial_blades(blades=24, thickness_mm=(5.0, 5.0)))
    assert check_clearances(ok).d_min == pytest.approx(
        face_chord(HUB_R, 5.0, math.pi / 12), abs=1e-6
    )


def test_fillet_larger_than_the_passage_is_an_input_error() -> None:
    params = load_design(FIXTURES / "small" / "design.toml")
    source = Path("small/spec.toml")
    figures = compute_figures(surfaces_of(params))
    too_big = dataclasses.replace(params, fillet_radius=figures.max_fillet_radius + 0.1)
    with pytest.raises(InputError) as error:
        check_clearances(surfaces_of(too_big, source))
    assert error.value.field == "blade.fillet_radius_mm"
    assert error.value.file == str(source)
    assert error.value.value == pytest.approx(figures.max_fillet_radius + 0.1)


# --- fixtures ----------------------------------------------------------------------------
def test_nine_blade_fixture_passes_eq1_for_the_10mm_ball() -> None:
    surfaces = build_surfaces(load_spec(FIXTURES / "nine_blade" / "spec.toml"))
    figures = check_clearances(surfaces)
    assert figures.blades == 9 and figures.splitters == 0
    assert figures.k == 1.2 and figures.finishing_allowance == 0.5
    assert figures.d_min >= 14.0  # eq. (1) needs 13 mm for r_max = 5 mm; keep a margin
    assert figures.r_max >= 5.0
    assert figures.rule_deviation < 1e-9
    json.dumps(figures.as_dict())  # JSON-ready


def test_fixtures_pass_clearance_checks() -> None:
    for name in ("small", "splitter"):
        surfaces = build_surfaces(load_spec(FIXTURES / name / "spec.toml"))
        figures = check_clearances(surfaces)
        assert surfaces.spec.fillet_radius <= figures.max_fillet_radius
        assert figures.d_min > 2 * surfaces.spec.finishing_allowance
