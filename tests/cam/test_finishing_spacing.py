"""Point spacing from a chordal tolerance (cam/finishing/spacing.py, ``chordal_tolerance_mm``)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.passes import passage_paths
from cam.finishing.paths import CutterPath, _solve_v, hub_foot
from cam.finishing.spacing import chord_errors, chord_spacing, curvature
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
NINE = ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml"
RADIUS, CAP = 3.0, 1.5


def _circle(radius: float, step: float, turn: float = math.pi) -> np.ndarray:
    """Points ``step`` apart (in angle times radius) on a circle in the z = 0 plane."""
    t = np.arange(0.0, turn, step / radius)
    return np.column_stack([radius * np.cos(t), radius * np.sin(t), np.zeros_like(t)])


def test_curvature_of_a_circle() -> None:
    kappa = curvature(_circle(12.0, 0.05))
    np.testing.assert_allclose(kappa, 1.0 / 12.0, rtol=1e-9)


def test_chord_spacing_keeps_the_sagitta_of_a_circle() -> None:
    for radius, tolerance in ((12.0, 0.01), (3.0, 0.002), (40.0, 0.05)):
        dense = _circle(radius, 0.02)
        spacing = chord_spacing(dense, tolerance, 10.0)
        assert spacing == pytest.approx(2.0 * math.sqrt(tolerance * (2 * radius - tolerance)),
                                        rel=1e-6)
        points = _circle(radius, spacing)
        t = np.arange(len(points) - 1) * spacing / radius + 0.5 * spacing / radius
        mids = radius * np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
        assert chord_errors(points, mids[:, None, :]).max() <= tolerance * (1 + 1e-6)
    straight = np.column_stack([np.linspace(0, 5, 20), np.zeros(20), np.zeros(20)])
    assert chord_spacing(straight, 0.01, 1.5) == 1.5
    assert chord_spacing(_circle(0.005, 0.001), 0.01, 1.5) == 1.5  # tolerance > radius


@pytest.fixture(scope="module")
def surfaces() -> ImpellerSurfaces:
    return build_surfaces(load_spec(NINE))


def _true_errors(path: CutterPath, surfaces: ImpellerSurfaces) -> np.ndarray:
    """Chord errors against the ideal curve evaluated half-way between the points."""
    hub = surfaces.hub
    if path.operation == "hub":  # phi is piecewise linear in s between the points
        s, phi = hub_foot(hub, path.centre)
        phi = np.unwrap(phi)
        mids = hub.offset(0.5 * (s[:-1] + s[1:]), 0.5 * (phi[:-1] + phi[1:]), RADIUS)
    else:
        wall = path.wall
        assert wall is not None and path.blade_v is not None
        u = wall.own_u(path.curve_u)
        um = 0.5 * (u[:-1] + u[1:])
        v_mid = _solve_v(wall, hub, RADIUS, um)
        if path.operation == "blade":  # v = v_junction(u) (1 - k / count)
            fraction = path.blade_v[0] / _solve_v(wall, hub, RADIUS, u[:1])[0]
            v_mid = v_mid * fraction
        mids = wall.blade.offset(um, v_mid, wall.side, RADIUS)
    return chord_errors(path.centre, mids[:, None, :])


def test_paths_keep_the_chordal_tolerance(surfaces: ImpellerSurfaces) -> None:
    stepover = scallop_stepover(RADIUS, 0.5)
    plain = passage_paths(surfaces, RADIUS, CAP, stepover)
    tight = 0.002
    paths = passage_paths(surfaces, RADIUS, CAP, stepover, chordal=tight)
    assert [p.name for p in paths] == [p.name for p in plain]
    worst_plain = max(float(_true_errors(p, surfaces).max()) for p in plain)
    assert worst_plain > tight  # the cap alone does not keep this tolerance
    for path, before in zip(paths, plain, strict=True):
        errors = _true_errors(path, surfaces)
        assert errors.max() <= tight * 1.05, path.name
        assert len(path) >= len(before)
        if path.operation == "junction":  # spaced along its own arc: the cap holds
            assert np.linalg.norm(np.diff(path.centre, axis=0), axis=1).max() <= CAP * 1.01
    assert sum(map(len, paths)) > sum(map(len, plain))


def test_a_loose_tolerance_keeps_the_cap(surfaces: ImpellerSurfaces) -> None:
    stepover = scallop_stepover(RADIUS, 0.5)
    plain = passage_paths(surfaces, RADIUS, CAP, stepover, blade=False)
    loose = passage_paths(surfaces, RADIUS, CAP, stepover, blade=False, chordal=1.0)
    for a, b in zip(plain, loose, strict=True):
        np.testing.assert_array_equal(a.centre, b.centre)


@pytest.mark.parametrize("value", [0.0, -0.01, math.nan, math.inf, True, "0.01"])
def test_bad_chordal_tolerance_is_refused(value: object) -> None:
    with pytest.raises(InputError, match="chordal_tolerance_mm"):
        FinishOptions.from_mapping({"chordal_tolerance_mm": value})


def test_cli_refuses_a_bad_chordal_tolerance(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code = main(["finish", str(NINE), "-m", "trunnion-500", "-t", "ball6_taper",
                 "-o", str(out), "--chordal-tol", "-0.5"])
    assert code == 2
    assert not out.exists()


def test_spec_table_refuses_a_bad_chordal_tolerance(tmp_path: Path) -> None:
    """``[machining.finish] chordal_tolerance_mm`` goes through the schema layer."""
    folder = tmp_path / "nine_blade"
    shutil.copytree(NINE.parent, folder)
    spec = folder / "spec.toml"
    text = spec.read_text()
    assert "[machining.finish]\n" in text
    spec.write_text(text.replace("[machining.finish]\n",
                                 "[machining.finish]\nchordal_tolerance_mm = 0.01\n"))
    assert main(["check", str(spec)]) == 0
    spec.write_text(text.replace("[machining.finish]\n",
                                 "[machining.finish]\nchordal_tolerance_mm = -0.01\n"))
    assert main(["check", str(spec)]) == 2
