"""Folded rolling-ball fillets trimmed to the union of the balls (geometry.fillet, issue 28).

Where the ball's centre line curves more tightly than 1 / r_f the arcs of
neighbouring sections cross and the envelope folds: nine_blade's suction side at the
cut trailing edge's corner (r_f x curvature 1.35, arc points 0.39 mm inside other
balls of the roll). The real fillet, the one a ball of radius r_f leaves, is the
boundary of the union of the balls: ``trim_fold`` moves the points there. Checked on
a closed form (a spindle torus), on nine_blade's tracks (folded) and round_te's
(regular: unchanged), and on the built nine_blade solid's fillet faces (slow).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from geometry.fillet import (
    FOLD_TOLERANCE,
    FilletTrack,
    blade_tracks,
    fillet_grid,
    fold_depth,
    fold_profile,
    fold_summary,
    loop_spine,
    trim_fold,
)
from geometry.impeller import Impeller
from geometry.outline import blade_loop
from geometry.solids import SolidSampling

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "impellers"


def _circle(a: float, n: int = 2000) -> np.ndarray:
    phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return np.column_stack([a * np.cos(phi), a * np.sin(phi), np.zeros_like(phi)])


@settings(max_examples=25, deadline=None)
@given(phi=st.floats(0.0, 2.0 * math.pi), psi=st.floats(0.0, 2.0 * math.pi))
def test_trim_fold_of_a_spindle_torus_keeps_the_outer_sheet_and_lands_on_the_union(
        phi: float, psi: float) -> None:
    # balls of radius 2 on a circle of radius 1 (r_f x curvature 2): the point at angle
    # psi of a ball's characteristic circle (meridional plane: radial x, axial z) is on
    # the union's boundary when its radial coordinate 1 + 2 cos(psi) >= 0 and stays;
    # beyond the axis it lies inside other balls and moves onto the boundary
    a, r = 1.0, 2.0
    spine = _circle(a)
    radial = np.array([math.cos(phi), math.sin(phi), 0.0])
    point = a * radial + r * (math.cos(psi) * radial + np.array([0.0, 0.0, math.sin(psi)]))
    moved = trim_fold(point[None, :], spine, r)[0]
    distance, _ = cKDTree(spine).query(moved)
    # on the boundary: in no ball, and on one (the discrete spine's chord sag is 1e-5)
    assert r - FOLD_TOLERANCE <= distance <= r + 1e-4
    if a + r * math.cos(psi) >= 0.01:
        assert np.allclose(moved, point, atol=1e-12)
    # and on the surface of the continuous torus union: |(rho - a, z)| = r
    rho = math.hypot(moved[0], moved[1])
    assert math.hypot(rho - a, moved[2]) == pytest.approx(r, abs=1e-4)


def test_fold_profile_of_a_circle_is_radius_over_circle_radius() -> None:
    p = np.linspace(0.0, 1.0, 41)
    a = 1.2 * p
    centre = np.column_stack([1.6 * np.cos(a), 1.6 * np.sin(a), np.zeros_like(a)])
    zeros = np.zeros_like(centre)
    track = FilletTrack("suction", p, p, centre, zeros, zeros, zeros, zeros, p, p)
    assert np.allclose(fold_profile(track, 2.0), 2.0 / 1.6, atol=1e-3)


def _tracks(name: str) -> tuple[list, float, list]:
    surfaces = Impeller.from_spec(FIXTURES / name / "spec.toml").surfaces
    spec = surfaces.spec
    blade = surfaces.blades[0]
    outline = blade_loop(blade, spec.leading_edge, spec.trailing_edge)
    radius = float(spec.fillet_radius)
    return blade_tracks(blade, surfaces.hub, outline, radius,
                        SolidSampling().per_kind()), radius, outline


@pytest.fixture(scope="module")
def nine_blade_tracks() -> tuple[list, float, list]:
    return _tracks("nine_blade")


def test_nine_blade_fillet_folds_at_the_suction_side_cut_trailing_edge_corner(
        nine_blade_tracks: tuple[list, float, list]) -> None:
    tracks, radius, outline = nine_blade_tracks
    rows = fold_summary(tracks, radius)
    folded = [k for k, row in enumerate(rows) if float(row["depth_mm"]) > 0.01]
    # the corner from the cut face to the suction side (loop segment 3) and the
    # suction side's first sections, whose arcs enter the corner's balls
    assert folded == [3, 4]
    assert outline[3].kind == "corner" and outline[3].role == "trailing_edge"
    assert float(rows[3]["ratio"]) > 1.2
    assert 0.3 < float(rows[3]["depth_mm"]) < 0.5
    # every other fillet of the loop is regular: the pressure side, the leading edge
    for k in (0, 5, 6, 7):
        assert float(rows[k]["depth_mm"]) < 1e-3


def test_trimmed_nine_blade_arcs_stay_out_of_every_ball_and_regular_arcs_do_not_move(
        nine_blade_tracks: tuple[list, float, list]) -> None:
    tracks, radius, _ = nine_blade_tracks
    spine = loop_spine(tracks)
    tree = cKDTree(spine)
    for track in tracks:
        raw = fillet_grid(track, radius, 41)
        trimmed = fillet_grid(track, radius, 41, spine)
        distance, _ = tree.query(trimmed.reshape(-1, 3))
        assert distance.min() >= radius - FOLD_TOLERANCE - 1e-9
        # contacts (the edges shared with blade and hub faces) never move
        assert np.array_equal(trimmed[:, [0, -1]], raw[:, [0, -1]])
        moved = np.linalg.norm(trimmed - raw, axis=-1).max()
        if fold_depth(track, radius, spine) < FOLD_TOLERANCE:
            assert moved == 0.0
        else:
            # the fold is trimmed away, not more: points move at most the fold's depth
            # along the ball's normal (plus the ridge's sideways slide)
            assert 0.05 < moved < 2.0 * radius


def test_round_te_fillet_does_not_fold() -> None:
    tracks, radius, _ = _tracks("round_te")
    rows = fold_summary(tracks, radius)
    assert max(float(row["ratio"]) for row in rows) < 1.0
    assert max(float(row["depth_mm"]) for row in rows) < FOLD_TOLERANCE


@pytest.mark.slow
def test_nine_blade_solid_fillet_faces_keep_out_of_the_rolling_balls() -> None:
    # the built faces (B-splines through the trimmed arcs), tessellated: before the
    # trimming their vertices reached 0.39 mm into the balls (7,932 over 0.05 mm)
    impeller = Impeller.from_spec(FIXTURES / "nine_blade" / "spec.toml")
    built = impeller.built
    mesh = impeller.mesh()
    triangles = np.asarray(mesh.triangles)[impeller.triangle_roles() == "fillet"]
    points = np.concatenate([triangles.reshape(-1, 3), triangles.mean(axis=1)])
    spine = np.concatenate([loop_spine(tracks) for tracks in built.tracks])
    distance, _ = cKDTree(spine).query(points)
    assert built.radius - distance.min() < 0.05
