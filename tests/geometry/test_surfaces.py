"""Closed-form checks of the camber lines, blade surfaces and revolved surfaces (M1)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geometry.camber import cylindrical_to_cartesian
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces, rotation_z
from tests.geometry.synthetic import (
    HUB_AXES,
    HUB_CENTRE,
    ellipse,
    write_synthetic_spec,
)


@pytest.fixture(scope="module")
def surfaces(tmp_path_factory: pytest.TempPathFactory):
    path = write_synthetic_spec(tmp_path_factory.mktemp("synthetic"))
    return build_surfaces(load_spec(path))


def test_camber_surface_passes_through_input_points(surfaces) -> None:
    spec = surfaces.spec
    blade = surfaces.blades[0]
    nodes = surfaces.shroud_curve.nodes
    shroud = blade.camber(nodes, 0.0)
    hub = blade.camber(surfaces.hub_curve.nodes, 1.0)
    assert np.abs(shroud - cylindrical_to_cartesian(spec.shroud_camber)).max() < 1e-6
    assert np.abs(hub - cylindrical_to_cartesian(spec.hub_camber)).max() < 1e-6


def test_pressure_suction_distance_along_normal_is_thickness(tmp_path: Path) -> None:
    path = write_synthetic_spec(
        tmp_path, thickness="thickness = { u = [0.0, 0.4, 1.0], mm = [1.0, 2.6, 1.4] }"
    )
    blade = build_surfaces(load_spec(path)).blades[1]
    rng = np.random.default_rng(7)
    u, v = rng.uniform(0, 1, 200), rng.uniform(0, 1, 200)
    gap = blade.pressure(u, v) - blade.suction(u, v)
    along = np.einsum("ij,ij->i", gap, blade.normal(u, v))
    assert np.abs(along - blade.thickness(u)).max() < 1e-3
    # and the gap is along the normal only
    assert np.abs(np.linalg.norm(gap, axis=1) - np.abs(along)).max() < 1e-9
    assert blade.thickness(np.array([0.0, 0.4, 1.0])) == pytest.approx([1.0, 2.6, 1.4])


def test_normal_points_to_pressure_side_and_is_unit(surfaces) -> None:
    blade = surfaces.blades[0]
    u, v = np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 5), indexing="ij")
    n = blade.normal(u, v)
    p = blade.camber(u, v)
    e_theta = np.stack([-p[..., 1], p[..., 0], np.zeros_like(p[..., 0])], -1)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
    assert np.all(np.einsum("...i,...i->...", n, e_theta) > 0)
    r_u, r_v = blade.camber_derivatives(u, v)
    assert np.abs(np.einsum("...i,...i->...", n, r_u)).max() < 1e-9
    assert np.abs(np.einsum("...i,...i->...", n, r_v)).max() < 1e-9


def test_derivatives_match_finite_differences(surfaces) -> None:
    blade = surfaces.blades[2]
    u, v, h = np.array([0.1, 0.5, 0.93]), np.array([0.2, 0.7, 0.5]), 1e-6
    r_u, r_v = blade.camber_derivatives(u, v)
    fd_u = (blade.camber(u + h, v) - blade.camber(u - h, v)) / (2 * h)
    fd_v = (blade.camber(u, v + h) - blade.camber(u, v - h)) / (2 * h)
    assert np.abs(r_u - fd_u).max() < 1e-5
    assert np.abs(r_v - fd_v).max() < 1e-5


def test_blades_are_rotated_copies(surfaces) -> None:
    u, v = np.array([0.3, 0.8]), np.array([0.1, 0.9])
    first = surfaces.blades[0].pressure(u, v)
    for k, blade in enumerate(surfaces.blades):
        expected = first @ rotation_z(k * surfaces.spec.pitch).T
        assert np.abs(blade.pressure(u, v) - expected).max() < 1e-9


def test_side_offset_is_at_distance_and_normal(surfaces) -> None:
    blade = surfaces.blades[0]
    u, v = np.linspace(0.05, 0.95, 7), np.linspace(0.05, 0.95, 7)
    for side in (1, -1):
        base = blade.side(u, v, side)
        off = blade.offset(u, v, side, 5.0)
        assert np.linalg.norm(off - base, axis=1) == pytest.approx(np.full(7, 5.0))
        n = blade.side_normal(u, v, side)
        h = 1e-5
        tangent_u = blade.side(u + h, v, side) - blade.side(u - h, v, side)
        assert np.abs(np.einsum("ij,ij->i", n, tangent_u)).max() < 1e-6 * 2 * h * 1e3
        # outward: away from the camber surface
        assert np.all(np.einsum("ij,ij->i", n, side * blade.normal(u, v)) > 0.9)


def test_ruling_is_unit_and_joins_shroud_to_hub(surfaces) -> None:
    blade = surfaces.blades[0]
    u = np.linspace(0, 1, 11)
    line = blade.camber(u, 1.0) - blade.camber(u, 0.0)
    unit = line / np.linalg.norm(line, axis=1, keepdims=True)
    assert np.abs(blade.ruling(u) - unit).max() < 1e-12


def test_hub_surface_is_the_revolved_contour(surfaces) -> None:
    hub = surfaces.hub
    s = np.linspace(0, 1, 9)
    zr = hub.meridian(s)
    # the spline through 25 ellipse samples stays close to the ellipse
    t = np.arcsin(np.clip((HUB_CENTRE[0] - zr[:, 0]) / HUB_AXES[0], -1, 1))
    exact = ellipse(HUB_CENTRE, HUB_AXES, t)
    assert np.abs(exact[:, 1] - zr[:, 1]).max() < 1e-3
    phi = 0.7
    point = hub.point(s, phi)
    assert np.allclose(np.hypot(point[:, 0], point[:, 1]), zr[:, 1])
    assert np.allclose(np.arctan2(point[:, 1], point[:, 0]), phi)


def test_hub_offset_signed_distance_round_trip(surfaces) -> None:
    hub = surfaces.hub
    s = np.linspace(0.05, 0.95, 13)
    phi = np.linspace(0, 2 * np.pi, 13)
    for distance in (-2.0, 0.0, 1.5, 5.0):
        points = hub.offset(s, phi, distance)
        assert hub.signed_distance(points) == pytest.approx(np.full(13, distance), abs=1e-6)
    # the normal points away from the axis at the (axial) nose, up at the (radial) rim
    assert hub.normal(0.0, 0.0)[0] > 0.99
    assert hub.normal(1.0, 0.0)[2] > 0.99


def test_shroud_normal_points_into_the_passage(surfaces) -> None:
    shroud = surfaces.shroud
    assert shroud.normal(0.0, 0.0)[0] < -0.99  # axial inlet: towards the axis
    assert shroud.normal(1.0, 0.0)[2] < -0.99  # radial outlet: down towards the hub


def test_splitters_start_at_their_fraction(tmp_path: Path) -> None:
    surfaces = build_surfaces(load_spec(write_synthetic_spec(tmp_path, splitters=1)))
    assert len(surfaces.splitters) == surfaces.spec.blades
    splitter = surfaces.splitters[0]
    main = surfaces.blades[0]
    le = splitter.camber(0.0, 0.5)
    expected = main.camber(0.4, 0.5) @ rotation_z(0.5 * surfaces.spec.pitch).T
    assert np.abs(le - expected).max() < 1e-9


def test_midspan_line_makes_a_non_ruled_blade(tmp_path: Path) -> None:
    surfaces = build_surfaces(load_spec(write_synthetic_spec(tmp_path, midspan=True)))
    blade = surfaces.blades[0]
    mid = cylindrical_to_cartesian(surfaces.spec.midspan_camber)
    nodes = surfaces.midspan_curve.nodes
    assert np.abs(blade.camber(nodes, 0.5) - mid).max() < 1e-6
    ruled = 0.5 * (blade.camber(nodes, 0.0) + blade.camber(nodes, 1.0))
    assert np.linalg.norm(blade.camber(nodes, 0.5) - ruled, axis=1).max() > 0.5


@pytest.mark.parametrize("midspan", [False, True])
def test_side_is_the_camber_point_plus_half_the_thickness_along_the_normal(
        tmp_path: Path, midspan: bool) -> None:
    """``side`` evaluates each camber line once for the point and the normal; it gives
    ``camber + side d/2 normal`` to the bit, on a main blade and a splitter (its own u),
    ruled and with a mid-span line; ``camber_frame`` gives ``camber``, ``R_u`` and
    ``normal`` to the bit, and ``point_and_derivative`` ``__call__`` and
    ``derivative``."""
    path = write_synthetic_spec(
        tmp_path, midspan=midspan,
        thickness="thickness = { u = [0.0, 0.4, 1.0], mm = [1.0, 2.6, 1.4] }")
    surfaces = build_surfaces(load_spec(path))
    rng = np.random.default_rng(11)
    u, v = rng.uniform(-0.05, 1.05, 300), rng.uniform(-0.1, 1.1, 300)
    blade = surfaces.blades[1]
    splitter = type(blade)(blade.shroud_curve, blade.hub_curve, blade._thickness,
                           angle=0.3, u_start=0.35, midspan=blade.midspan_curve)
    for b in (blade, splitter):
        assert (b.midspan_curve is not None) == midspan
        for side in (1, -1):
            half = 0.5 * side * b.thickness(u)[:, None]
            assert np.array_equal(b.side(u, v, side), b.camber(u, v) + half * b.normal(u, v))
        assert np.array_equal(b.side(0.3, 0.6, 1), b.side(np.array([0.3]), 0.6, 1)[0])
        frame = b.camber_frame(u, v)
        want = (b.camber(u, v), b.camber_derivatives(u, v)[0], b.normal(u, v))
        assert all(np.array_equal(x, y) for x, y in zip(frame, want, strict=True))
        # side_normal: central differences of the side, oriented like side * N
        n = b.side_normal(u, v, -1)
        assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
        assert (np.einsum("ij,ij->i", n, -b.normal(u, v)) > 0.9).all()
        assert np.allclose(b.side_normal(0.4, 0.5, -1), b.side_normal(np.array([0.4]), 0.5, -1)[0],
                           rtol=0.0, atol=1e-9)
    curve = blade.shroud_curve
    point, slope = curve.point_and_derivative(u)
    assert np.array_equal(point, curve(u)) and np.array_equal(slope, curve.derivative(u))
