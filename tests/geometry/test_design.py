"""Parametric design generator: closed forms, round trip, validation, fixtures."""

from __future__ import annotations

import dataclasses
import math
import runpy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geometry.camber import cylindrical_to_cartesian
from geometry.design import (
    DesignParameters,
    bezier,
    generate,
    integrate_blade_angle,
    load_design,
)
from geometry.design_files import camber_csv_text, write_design
from geometry.spec import load_spec
from impeller_cam.errors import InputError

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "impellers"
FIXTURE_NAMES = ("nine_blade", "round_te", "small", "splitter", "straight")
#: Half a unit in the 6th decimal written to the files (mm, and deg -> rad).
WRITTEN_MM = 0.5e-6 + 1e-12
WRITTEN_RAD = math.radians(0.5e-6) + 1e-12


def cylinder_params(**changes: Any) -> DesignParameters:
    """Axial passage between cylinders r = 20 (hub) and r = 40 (shroud), z 60 -> 10."""
    base = DesignParameters(
        name="cylinder",
        blades=6,
        hub_control=((60.0, 20.0), (10.0, 20.0)),
        shroud_control=((60.0, 40.0), (10.0, 40.0)),
        shroud_knots=(0.0, 1.0),
        shroud_angle=(0.0, 0.0),
        hub_knots=(0.0, 1.0),
        hub_angle=(0.0, 0.0),
        bore_radius=5.0,
        thickness_mm=(2.0, 2.0),
    )
    return dataclasses.replace(base, **changes)


def compressor_params(**changes: Any) -> DesignParameters:
    """A small backswept compressor with a wrap law (quick to generate)."""
    base = DesignParameters(
        name="compressor",
        blades=7,
        hub_control=((40.0, 12.0), (25.0, 12.0), (7.0, 24.0), (5.0, 45.0)),
        shroud_control=((40.0, 30.0), (26.0, 30.0), (13.0, 33.0), (12.0, 45.0)),
        shroud_knots=(0.0, 0.5, 1.0),
        shroud_angle=(0.0, math.radians(-25.0), math.radians(-45.0)),
        hub_knots=(0.0, 0.5, 1.0),
        hub_angle=(0.0, math.radians(-15.0), math.radians(-45.0)),
        bore_radius=5.0,
        thickness_mm=(1.5, 1.5),
        camber_points=11,
        contour_points=21,
        fillet_radius=1.0,
    )
    return dataclasses.replace(base, **changes)


# --- closed forms ----------------------------------------------------------------------
def test_bezier_hand_computed() -> None:
    control = np.array([[0.0, 0.0], [2.0, 4.0], [6.0, 0.0]])
    points = bezier(control, np.array([0.0, 0.5, 1.0]))
    # quadratic: B(1/2) = (P0 + 2 P1 + P2) / 4 = (2.5, 2.0)
    np.testing.assert_allclose(points, [[0.0, 0.0], [2.5, 2.0], [6.0, 0.0]], atol=1e-15)


def test_constant_blade_angle_on_cylinder_is_a_helix() -> None:
    # theta(m) = tan(beta) m / R exactly (trapezoidal rule on a constant integrand)
    m = np.linspace(0.0, 50.0, 11)
    theta = integrate_blade_angle(m, np.full(11, 20.0), np.full(11, math.radians(30.0)), 0.1)
    np.testing.assert_allclose(theta, 0.1 + math.tan(math.radians(30.0)) * m / 20.0, atol=1e-15)


def test_generator_blade_angle_helix() -> None:
    beta = math.radians(-35.0)
    params = cylinder_params(
        angle_law="blade_angle",
        shroud_angle=(beta, beta),
        hub_angle=(beta, beta),
        hub_theta_le=math.radians(4.0),
    )
    design = generate(params)
    for line, radius, theta_le in (
        (design.shroud_camber, 40.0, 0.0),
        (design.hub_camber, 20.0, math.radians(4.0)),
    ):
        m = 60.0 - line[:, 2]  # meridional length along the axial contour
        np.testing.assert_allclose(line[:, 0], radius, atol=1e-9)
        np.testing.assert_allclose(m, np.linspace(0.0, 50.0, params.camber_points), atol=1e-9)
        np.testing.assert_allclose(line[:, 1], theta_le + math.tan(beta) * m / radius, atol=1e-12)


def test_generator_blade_angle_log_spiral_on_a_disc() -> None:
    # radial disc passage: dm = dr, so theta = tan(beta) ln(r / r1), a logarithmic spiral
    beta = math.radians(40.0)
    params = cylinder_params(
        hub_control=((10.0, 20.0), (10.0, 80.0)),
        shroud_control=((30.0, 20.0), (30.0, 80.0)),
        angle_law="blade_angle",
        shroud_angle=(beta, beta),
        hub_angle=(beta, beta),
    )
    design = generate(params)
    r = design.hub_camber[:, 0]
    np.testing.assert_allclose(r, np.linspace(20.0, 80.0, params.camber_points), atol=1e-9)
    expected = math.tan(beta) * np.log(r / 20.0)
    np.testing.assert_allclose(design.hub_camber[:, 1], expected, atol=2e-7)
    np.testing.assert_allclose(design.shroud_camber[:, 1], expected, atol=2e-7)


def test_wrap_law_passes_through_knots_and_contours() -> None:
    params = compressor_params()
    design = generate(params)
    # camber m = i / 10; the knots 0, 0.5, 1 are samples 0, 5, 10
    np.testing.assert_allclose(design.shroud_camber[[0, 5, 10], 1], params.shroud_angle, atol=1e-15)
    np.testing.assert_allclose(design.hub_camber[[0, 5, 10], 1], params.hub_angle, atol=1e-15)
    # end points of the camber lines are the Bezier end points (blade spans whole contour)
    np.testing.assert_allclose(design.hub_camber[0, [2, 0]], params.hub_control[0], atol=1e-9)
    np.testing.assert_allclose(design.hub_camber[-1, [2, 0]], params.hub_control[-1], atol=1e-9)
    # every camber point lies on the exact Bezier contour
    dense = bezier(np.array(params.hub_control), np.linspace(0, 1, 200001))
    for z, r in design.hub_camber[:, [2, 0]]:
        assert np.hypot(dense[:, 0] - z, dense[:, 1] - r).min() < 1e-3


def test_blade_span_fraction_moves_the_leading_edge() -> None:
    design = generate(cylinder_params(hub_blade=(0.2, 1.0)))
    assert design.hub_camber[0, 2] == pytest.approx(60.0 - 0.2 * 50.0, abs=1e-9)
    assert design.shroud_camber[0, 2] == pytest.approx(60.0, abs=1e-12)


# --- round trip and writing --------------------------------------------------------------
def _assert_round_trip(params: DesignParameters, folder: Path) -> None:
    design = generate(params)
    spec = load_spec(write_design(params, folder))
    for name in ("shroud_camber", "hub_camber", "midspan_camber"):
        ours, theirs = getattr(design, name), getattr(spec, name)
        if ours is None:
            assert theirs is None
            continue
        np.testing.assert_allclose(theirs[:, [0, 2]], ours[:, [0, 2]], rtol=0, atol=WRITTEN_MM)
        np.testing.assert_allclose(theirs[:, 1], ours[:, 1], rtol=0, atol=WRITTEN_RAD)
    for name in ("hub_contour", "shroud_contour"):
        np.testing.assert_allclose(getattr(spec, name), getattr(design, name), atol=WRITTEN_MM)
    assert spec.blades == params.blades and spec.name == params.name
    np.testing.assert_allclose(spec.thickness_mm, params.thickness_mm, atol=WRITTEN_MM)
    np.testing.assert_allclose(spec.thickness_u, params.thickness_u)
    assert (spec.leading_edge, spec.trailing_edge) == (params.leading_edge, params.trailing_edge)
    assert spec.fillet_radius == params.fillet_radius
    assert (spec.splitters, spec.splitter_start) == (params.splitters, params.splitter_start)
    assert spec.bore_radius == params.bore_radius
    assert spec.finishing_allowance == params.finishing_allowance
    assert spec.stock_allowance == params.stock_allowance


def test_round_trip_generate_write_load(tmp_path: Path) -> None:
    params = compressor_params(
        thickness_u=(0.0, 0.3, 1.0),
        thickness_mm=(1.2, 2.1, 1.6),
        splitters=1,
        splitter_start=0.4,
        midspan_wrap_offset=math.radians(3.0),
        leading_edge="cut",
    )
    _assert_round_trip(params, tmp_path / "variant")
    assert (tmp_path / "variant" / "mid_camber.csv").is_file()


@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    wrap=st.floats(-70.0, 70.0),
    middle=st.floats(0.2, 0.8),
    blades=st.integers(3, 15),
    thickness=st.floats(0.5, 3.0),
)
def test_round_trip_property(
    tmp_path: Path, wrap: float, middle: float, blades: int, thickness: float
) -> None:
    angles = (0.0, math.radians(wrap * middle), math.radians(wrap))
    params = compressor_params(
        blades=blades, thickness_mm=(thickness, thickness), shroud_angle=angles, hub_angle=angles
    )
    _assert_round_trip(params, tmp_path / f"rt_{blades}")


def test_writing_is_deterministic_and_removes_stale_midspan(tmp_path: Path) -> None:
    non_ruled = compressor_params(midspan_wrap_offset=math.radians(-2.0))
    write_design(non_ruled, tmp_path)
    first = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    write_design(non_ruled, tmp_path)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == first
    assert b"-0.000000" not in b"".join(first.values())
    write_design(compressor_params(), tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "hub_camber.csv",
        "shroud_camber.csv",
        "spec.toml",
    ]
    assert load_spec(tmp_path / "spec.toml").midspan_camber is None


def test_csv_formatting() -> None:
    text = camber_csv_text(np.array([[10.0, -1e-12, 2.5], [11.25, math.radians(-30.0), 0.0]]))
    assert text == "r,theta_deg,z\n10.000000,0.000000,2.500000\n11.250000,-30.000000,0.000000\n"


def test_midspan_offset_zero_is_on_the_rulings() -> None:
    # the mid-span line of a non-ruled variant, minus its offset, lies on the rulings
    offset = math.radians(5.0)
    design = generate(compressor_params(midspan_wrap_offset=offset))
    mid = design.midspan_camber
    assert mid is not None
    m = np.linspace(0.0, 1.0, len(mid))
    back = mid.copy()
    back[:, 1] -= offset * m
    expected = 0.5 * (
        cylindrical_to_cartesian(design.shroud_camber) + cylindrical_to_cartesian(design.hub_camber)
    )
    np.testing.assert_allclose(cylindrical_to_cartesian(back), expected, atol=1e-9)


def test_failed_generation_writes_nothing(tmp_path: Path) -> None:
    # shroud contour pushed below the hub: hub and shroud cross
    crossing = compressor_params(
        shroud_control=((30.0, 10.0), (20.0, 14.0), (3.0, 26.0), (2.0, 45.0))
    )
    with pytest.raises(InputError):
        write_design(crossing, tmp_path / "out")
    assert not (tmp_path / "out").exists()


# --- validation ------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("changes", "field", "value"),
    [
        ({"blades": 0}, "impeller.blades", 0),
        ({"name": "a b"}, "impeller.name", "a b"),
        ({"shroud_knots": (0.0, 0.7, 0.5)}, "camber.shroud.m", [0.0, 0.7, 0.5]),
        ({"hub_angle": (0.0, math.radians(10.0), 0.0)}, "camber.hub.theta_deg", [0.0, 10.0, 0.0]),
        ({"angle_law": "spiral"}, "camber.law", "spiral"),
        (
            {"angle_law": "blade_angle", "shroud_angle": (0.0, math.radians(88.0))},
            "camber.shroud.beta_deg",
            [0.0, 88.0],
        ),
        ({"hub_blade": (0.6, 0.2)}, "meridional.hub_blade", [0.6, 0.2]),
        (
            {"hub_control": ((60.0, 20.0), (60.0, 20.0))},
            "meridional.hub",
            [(60.0, 20.0), (60.0, 20.0)],
        ),
        ({"bore_radius": 25.0}, "hub.bore_radius_mm", 25.0),
        ({"thickness_mm": (2.0, -1.0)}, "blade.thickness.mm", [2.0, -1.0]),
        ({"leading_edge": "sharp"}, "blade.leading_edge", "sharp"),
        ({"fillet_radius": -1.0}, "blade.fillet_radius_mm", -1.0),
        ({"splitters": 2}, "splitters.count", 2),
        ({"splitter_start": 0.95}, "splitters.start_fraction", 0.95),
        ({"finishing_allowance": float("nan")}, "allowances.finishing_mm", None),
        ({"camber_points": 3}, "camber.points", 3),
        ({"midspan_wrap_offset": math.radians(60.0)}, "camber.midspan_wrap_offset_deg", 60.0),
    ],
)
def test_bad_parameters_name_field_and_value(
    changes: dict[str, object], field: str, value: object
) -> None:
    with pytest.raises(InputError) as error:
        cylinder_params(**changes)
    assert error.value.field == field
    if value is not None:
        shown = error.value.value
        if isinstance(value, float):
            assert shown == pytest.approx(value)
        else:
            assert shown == value
    assert error.value.accepted


def _design_toml(folder: Path, replace: tuple[str, str] | None = None) -> Path:
    text = (FIXTURES / "small" / "design.toml").read_text()
    if replace is not None:
        assert replace[0] in text
        text = text.replace(*replace)
    path = folder / "design.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("replace", "field"),
    [
        (("blades = 6", 'blades = "six"'), "impeller.blades"),
        (("blades = 6", ""), "impeller.blades"),
        (('law = "wrap"', 'law = "blade_angle"'), "camber.shroud.beta_deg"),
        (
            (
                "m = [0.0, 0.5, 1.0]\ntheta_deg = [0.0, -22.0, -40.0]",
                "m = [0.0, 0.5, 1.0]\ntheta_deg = [0.0, -22.0]",
            ),
            "camber.shroud.theta_deg",
        ),
        (("thickness_mm = 1.5", "thickness_mm = [1.5, 2.0"), None),
        (
            ("thickness_mm = 1.5", 'thickness = { u = [0.0, 1.0], mm = ["a", 1.0] }'),
            "blade.thickness.mm",
        ),
        (("fillet_radius_mm = 1.0", "fillet_radius_mm = -0.5"), "blade.fillet_radius_mm"),
        (("hub = [[29.5, 9.0],", "hub = [[29.5],"), "meridional.hub"),
    ],
)
def test_bad_design_toml_names_file_and_field(
    tmp_path: Path, replace: tuple[str, str], field: str | None
) -> None:
    path = _design_toml(tmp_path, replace)
    with pytest.raises(InputError) as error:
        load_design(path)
    assert error.value.file == str(path)
    assert error.value.field == field


def test_design_toml_angles_are_degrees(tmp_path: Path) -> None:
    params = load_design(_design_toml(tmp_path))
    assert params.name == "small" and params.blades == 6
    assert params.shroud_angle == pytest.approx(tuple(map(math.radians, (0.0, -22.0, -40.0))))
    assert params.thickness_mm == (1.5, 1.5) and params.thickness_u == (0.0, 1.0)


# --- fixtures --------------------------------------------------------------------------
def test_committed_fixtures_equal_a_fresh_regeneration(tmp_path: Path) -> None:
    script = runpy.run_path(str(FIXTURES / "regenerate.py"))
    assert script["main"](["--out", str(tmp_path)]) == 0
    for name in FIXTURE_NAMES:
        fresh = sorted(p.name for p in (tmp_path / name).iterdir())
        assert fresh[-1] == "spec.toml"
        for file in fresh:
            committed = FIXTURES / name / file
            assert committed.read_bytes() == (tmp_path / name / file).read_bytes(), committed
        stale = {p.name for p in (FIXTURES / name).iterdir()} - set(fresh)
        assert stale <= {"design.toml", "README.md"}


@pytest.mark.parametrize("name", FIXTURE_NAMES)
def test_fixture_specs_load(name: str) -> None:
    spec = load_spec(FIXTURES / name / "spec.toml")
    assert spec.name == name
    assert spec.midspan_camber is None  # fixtures are ruled (flank/ruling-based CAM)
    assert (FIXTURES / name / "README.md").is_file()
