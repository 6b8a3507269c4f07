"""Cutter-centre paths (M3 step 1): junction balls touch hub and blade at R, passes.

The distances are measured independently of the path construction: the hub by a dense
polyline of its meridian, the blade by a bounded least-squares foot-point search.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares

from cam.finishing.options import scallop_stepover
from cam.finishing.passes import SPLITTER_MARGIN, hub_passes, passage_paths
from cam.finishing.paths import (
    CutterPath,
    blade_distance,
    body_distance,
    hub_foot,
    junction_path,
    passage_walls,
    rotate_path,
)
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "fixtures" / "impellers"
#: Acceptance: every junction ball centre at R +/- 0.01 mm from hub and blade.
JUNCTION_TOLERANCE = 0.01


@cache
def surfaces_of(name: str) -> ImpellerSurfaces:
    return build_surfaces(load_spec(FIXTURES / name / "spec.toml"))


def hub_distance_dense(surfaces: ImpellerSurfaces, points: np.ndarray) -> np.ndarray:
    """Distance from the hub surface of revolution via a dense meridian polyline."""
    zr = surfaces.hub.meridian(np.linspace(0.0, 1.0, 40001))
    q = np.column_stack([points[:, 2], np.hypot(points[:, 0], points[:, 1])])
    a, b = zr[:-1], zr[1:]
    ab = b - a
    out = np.empty(len(q))
    for i, p in enumerate(q):
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
        out[i] = np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1))
    return out


def blade_distance_lsq(blade, side: int, points: np.ndarray,  # type: ignore[no-untyped-def]
                       v_max: float = 1.2) -> np.ndarray:
    """Distance from a blade side surface: coarse grid seed, then least squares in (u, v)
    (v up to ``v_max``: 1 is the hub)."""
    u, v = np.meshgrid(np.linspace(0, 1, 101), np.linspace(0, min(1.1, v_max), 56),
                       indexing="ij")
    grid = blade.side(u, v, side).reshape(-1, 3)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        k = int(np.argmin(np.linalg.norm(grid - p, axis=1)))
        x0 = [u.ravel()[k], v.ravel()[k]]
        fit = least_squares(lambda x, p=p: blade.side(x[0], x[1], side) - p, x0,
                            bounds=([0, -0.1], [1, v_max]), xtol=1e-12, ftol=1e-12)
        out[i] = float(np.linalg.norm(fit.fun))
    return out


@pytest.mark.parametrize(("name", "radius"), [("small", 2.0), ("nine_blade", 3.0),
                                              ("splitter", 3.0)])
def test_junction_ball_touches_hub_and_blade(name: str, radius: float) -> None:
    surfaces = surfaces_of(name)
    for first, second in passage_walls(surfaces):
        for wall, opposite in ((first, second), (second, first)):
            path = junction_path(wall, opposite, surfaces.hub, radius, spacing=0.25)
            sample = path.centre[:: max(len(path) // 12, 1)]
            hub = hub_distance_dense(surfaces, sample)
            blade = blade_distance_lsq(wall.blade, wall.side, sample)
            assert np.abs(hub - radius).max() < JUNCTION_TOLERANCE, (wall.label, hub)
            assert np.abs(blade - radius).max() < JUNCTION_TOLERANCE, (wall.label, blade)
            # the product's own report (its foot-point search) agrees with this one
            step = max(len(path) // 12, 1)
            assert path.blade_v is not None
            own = blade_distance(wall, sample, wall.own_u(path.curve_u)[::step],
                                 path.blade_v[::step])
            assert np.abs(own - blade).max() < 1e-3  # (u clipped at the blade edges)
            # spacing and direction: leading to trailing edge, no step over 0.25 mm
            steps = np.linalg.norm(np.diff(path.centre, axis=0), axis=1)
            assert steps.max() <= 0.25 + 1e-9
            # it runs from edge to edge, or is trimmed where the hub contour ends
            s_ends = surfaces.hub.closest_s(path.centre[[0, -1], 2],
                                            np.hypot(*path.centre[[0, -1], :2].T))
            assert (path.curve_u[0] == pytest.approx(wall.blade.u_start)
                    or s_ends[0] < 1e-6)
            assert path.curve_u[-1] == pytest.approx(1.0) or s_ends[1] > 1 - 1e-6


def test_nine_blade_junction_has_about_the_papers_point_count() -> None:
    surfaces = surfaces_of("nine_blade")
    first, second = passage_walls(surfaces)[0]
    path = junction_path(first, second, surfaces.hub, 3.0, spacing=0.25)
    # the paper: 475 CC points along the pressure-side junction; ours at 0.25 mm spacing
    assert 400 <= len(path) <= 560


def test_passes_cover_blade_and_hub_with_the_scallop_stepover() -> None:
    surfaces = surfaces_of("small")
    radius, scallop = 2.0, 0.2
    step = scallop_stepover(radius, scallop)
    paths = passage_paths(surfaces, radius, 0.5, step)
    ops = [p.operation for p in paths]
    assert ops[:2] == ["junction", "junction"]
    blade = [p for p in paths if p.operation == "blade"]
    # the passes across the passage (not the junctions' continuations along the hub)
    hub = [p for p in paths if p.operation == "hub" and not p.name.endswith((".le", ".te"))]
    assert blade and hub
    pressure = [p for p in blade if "blade0.pressure" in p.name]
    # neighbouring passes (same u) are at most one stepover apart, and the last is at the tip
    for a, b in zip(pressure[:-1], pressure[1:], strict=True):
        gap = np.linalg.norm(a.centre - b.centre, axis=1)
        assert gap.max() <= step * 1.05  # offset surface spacing ~ blade spacing
    tip = pressure[-1].wall
    assert tip is not None
    assert pressure[-1].blade_v == pytest.approx(np.zeros(len(pressure[-1])), abs=1e-12)
    # hub passes lie on the hub offset, between the two junctions, across the passage
    for p in hub:
        assert np.abs(surfaces.hub.signed_distance(p.centre) - radius).max() < 1e-6
    width = [np.linalg.norm(h1.centre - h0.centre, axis=1).max()
             for h0, h1 in zip(hub[:-1], hub[1:], strict=True)]
    assert max(width) <= step * 1.05
    # the outermost hub passes are within a stepover of the junction paths' hub feet
    for junction, edge in ((paths[0], hub[0]), (paths[1], hub[-1])):
        gap = np.min(np.linalg.norm(edge.centre[:, None] - junction.centre[None], axis=2),
                     axis=1)
        assert np.median(gap) <= step * 1.05


def test_rotated_path_is_the_same_path_in_the_next_passage() -> None:
    surfaces = surfaces_of("small")
    first, second = passage_walls(surfaces)[0]
    path = junction_path(first, second, surfaces.hub, 2.0, spacing=1.0)
    turned: CutterPath = rotate_path(path, 2, surfaces.spec.pitch)
    assert turned.name.startswith("p2.")
    r0 = np.hypot(path.centre[:, 0], path.centre[:, 1])
    assert np.hypot(turned.centre[:, 0], turned.centre[:, 1]) == pytest.approx(r0)
    d_theta = np.arctan2(turned.centre[:, 1], turned.centre[:, 0]) - np.arctan2(
        path.centre[:, 1], path.centre[:, 0])
    assert np.mod(d_theta, 2 * math.pi) == pytest.approx(
        np.full(len(path), 2 * surfaces.spec.pitch), abs=1e-9)


def test_ball_smaller_than_the_fillet_is_refused() -> None:
    surfaces = surfaces_of("nine_blade")  # fillet 2.5 mm
    with pytest.raises(InputError, match="smaller than the fillet radius"):
        passage_paths(surfaces, 2.0, 1.0, 1.0)


def test_inlet_hub_passes_end_where_the_cutter_meets_the_splitter() -> None:
    """Hub passes ahead of the splitter end at the real distance (defect: fixed 2R).

    Ball (R = 2) and flutes (8 mm above the ball centre, along the pass's initial
    axis) keep R + SPLITTER_MARGIN from the splitter, leading edge included; passes
    that run into the splitter end exactly there (bisection), the others run on to
    the splitter junction's start.
    """
    surfaces = surfaces_of("splitter")
    radius, reach = 2.0, 8.0
    (main0, split_suction), (split_pressure, main1) = passage_walls(surfaces)
    splitter = surfaces.splitters[0]
    ja = junction_path(main0, split_suction, surfaces.hub, radius, 2.0)
    jb = junction_path(main1, split_pressure, surfaces.hub, radius, 2.0)
    js = junction_path(split_suction, main0, surfaces.hub, radius, 2.0)
    # body_distance: the splitter junction balls touch the splitter side at R
    assert np.abs(body_distance(splitter, js.centre) - radius).max() < 0.005
    s_split = hub_foot(surfaces.hub, js.centre)[0][0]
    passes = hub_passes(ja, jb, surfaces.hub, radius, 1.0, label="i",
                        s_limits=(0.0, s_split), keep_clear=splitter, reach=reach)
    assert len(passes) > 10 and all(p.open_end for p in passes)
    ends = []
    for p in passes:
        up = p.reference_axis
        heights = np.linspace(0.0, reach, 33)
        points = p.centre[:, None, :] + heights[None, :, None] * up[:, None, :]
        clear = body_distance(splitter, points.reshape(-1, 3)).reshape(len(p), -1).min(axis=1)
        assert clear.min() >= radius + SPLITTER_MARGIN - 0.01  # 33 samples vs 9 in the trim
        s_end = hub_foot(surfaces.hub, p.centre[-1:])[0][0]
        ends.append((clear[-1] - radius, s_end))
    trimmed = [gap for gap, s_end in ends if s_end < s_split - 1e-6]
    assert trimmed, "the middle passes must be stopped by the splitter"
    assert np.max(np.abs(np.array(trimmed) - SPLITTER_MARGIN)) < 0.02
    # the passes next to the main blades run up to the splitter junction's start
    assert ends[0][1] == pytest.approx(s_split, abs=1e-9)
    assert ends[-1][1] == pytest.approx(s_split, abs=1e-9)


@pytest.mark.parametrize(("name", "radius", "scallop"), [("small", 2.0, 0.8),
                                                         ("nine_blade", 3.0, 0.2)])
def test_hub_passes_run_over_both_junction_paths_hub_ranges(name: str, radius: float,
                                                            scallop: float) -> None:
    """Defect: the passes stopped at the shorter junction path. On the small fixture the
    suction-side junction ball ends 2.1 mm (of hub meridian) upstream of the trailing
    edge, and the finished hub kept up to 2.2 mm of roughing stock along it."""
    surfaces = surfaces_of(name)
    step = scallop_stepover(radius, scallop)
    paths = passage_paths(surfaces, radius, 0.5, step, blade=False)
    ja, jb = paths[0], paths[1]
    feet = [hub_foot(surfaces.hub, j.centre)[0] for j in (ja, jb)]
    lo, hi = min(f[0] for f in feet), max(f[-1] for f in feet)
    assert hi - min(f[-1] for f in feet) > 0.01  # the junctions end at different s
    te = surfaces.spec.hub_camber[-1]  # (r, theta, z)
    s_te = surfaces.hub.closest_s(np.array([te[2]]), np.array([te[0]]))[0]
    assert hi >= s_te  # the passes reach the trailing edge on the hub
    hub = [p for p in paths if p.operation == "hub" and not p.name.endswith((".le", ".te"))]
    (wall_a, wall_b), = passage_walls(surfaces)
    for p in hub:
        s = hub_foot(surfaces.hub, p.centre)[0]
        assert s[0] == pytest.approx(lo, abs=1e-9) and s[-1] == pytest.approx(hi, abs=1e-9)
        assert np.all(np.diff(s) > 0)
        # no longer steps than the junction paths'
        assert np.linalg.norm(np.diff(p.centre, axis=0), axis=1).max() <= 0.5 * 1.05
    for p in (hub[0], hub[-1]):
        # the passes next to the walls keep the ball clear of both walls (their sides
        # above the hub; every 4th centre and the extended ends)
        pick = np.union1d(np.arange(0, len(p), 4), [0, 1, len(p) - 2, len(p) - 1])
        clear = np.minimum(
            blade_distance_lsq(wall_a.blade, wall_a.side, p.centre[pick], v_max=1.0),
            blade_distance_lsq(wall_b.blade, wall_b.side, p.centre[pick], v_max=1.0))
        assert clear.min() >= radius - 1e-3, p.name


@pytest.mark.parametrize(("name", "radius", "scallop"), [("small", 2.0, 0.8),
                                                         ("nine_blade", 3.0, 0.2)])
def test_junctions_continue_along_the_hub_to_the_passes_ends(name: str, radius: float,
                                                             scallop: float) -> None:
    """Defect: beyond the shorter junction path nothing ran next to its wall (the last
    hub pass is a stepover away), so the small fixture's hub kept 2.2 mm of roughing
    stock in the trailing-edge corner beside the suction side. Each junction now goes
    on along the hub (lambda = 0 or 1) to the hub passes' ends: it starts on the
    junction's end ball, keeps R from both walls (independent least-squares distance)
    and the junction with its continuations spans every hub pass's range."""
    surfaces = surfaces_of(name)
    paths = passage_paths(surfaces, radius, 0.5, scallop_stepover(radius, scallop),
                          blade=False)
    (wall_a, wall_b), = passage_walls(surfaces)
    hub = [p for p in paths if p.operation == "hub"]
    inner = [p for p in hub if not p.name.endswith((".le", ".te"))]
    lo = hub_foot(surfaces.hub, inner[0].centre)[0][0]
    hi = hub_foot(surfaces.hub, inner[0].centre)[0][-1]
    edges = [p for p in hub if p.name.endswith((".le", ".te"))]
    assert any(p.name.endswith(".te") for p in edges)  # the junctions end apart
    for junction in paths[:2]:
        mine = [p for p in edges
                if np.allclose(p.centre[0 if p.name.endswith(".te") else -1],
                               junction.centre[-1 if p.name.endswith(".te") else 0],
                               atol=1e-6)]
        covered = [hub_foot(surfaces.hub, p.centre)[0][[0, -1]] for p in [junction, *mine]]
        assert min(c[0] for c in covered) == pytest.approx(lo, abs=1e-6), junction.name
        assert max(c[1] for c in covered) == pytest.approx(hi, abs=1e-6), junction.name
    for p in edges:
        clear = np.minimum(
            blade_distance_lsq(wall_a.blade, wall_a.side, p.centre, v_max=1.0),
            blade_distance_lsq(wall_b.blade, wall_b.side, p.centre, v_max=1.0))
        assert clear.min() >= radius - 1e-3, p.name
        assert hub_distance_dense(surfaces, p.centre) == pytest.approx(radius, abs=1e-3)
