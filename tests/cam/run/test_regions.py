"""Region classification of verify/regions.json (fast, hand-computed cases)."""

from __future__ import annotations

import numpy as np
import pytest

from cam.run.regions import closest_roles, on_tip_edge, shroud_offset

#: A cylindrical shroud at r = 20 (z from 10 down to 0) over a hub at r = 10.
SHROUD = np.array([[10.0, 20.0], [5.0, 20.0], [0.0, 20.0]])
HUB = np.array([[10.0, 10.0], [0.0, 10.0]])


def point(z: float, r: float, theta: float = 0.7) -> np.ndarray:
    return np.array([r * np.cos(theta), r * np.sin(theta), z])


def test_shroud_offset_is_positive_beyond_the_shroud_envelope() -> None:
    points = np.array([point(5.0, 21.0), point(2.0, 19.5), point(12.0, 21.0),
                       point(13.0, 24.0), point(-3.0, 16.0)])
    # 1 mm outside, 0.5 mm inside; beyond the end (z = 10, r = 20): sqrt(2^2 + 1^2)
    # and 5 mm (a 3, 4 triangle) from the end point outward, 5 mm from the other end
    # (z = 0) inward
    expected = [1.0, -0.5, np.sqrt(5.0), 5.0, -5.0]
    assert shroud_offset(points, SHROUD, HUB) == pytest.approx(expected)


def test_shroud_offset_does_not_depend_on_the_contour_direction() -> None:
    points = np.array([point(5.0, 21.0), point(2.0, 19.5)])
    assert shroud_offset(points, SHROUD[::-1], HUB[::-1]) == pytest.approx([1.0, -0.5])


def test_shroud_offset_of_a_sloped_contour() -> None:
    # shroud from (z, r) = (10, 10) to (0, 20): the outward normal is (-1, -1)/sqrt 2
    # rotated to the side away from a hub at (10, 0)..(0, 10)
    shroud = np.array([[10.0, 10.0], [0.0, 20.0]])
    hub = np.array([[10.0, 0.0], [0.0, 10.0]])
    points = np.array([point(6.0, 16.0), point(4.0, 14.0)])
    assert shroud_offset(points, shroud, hub) == pytest.approx([np.sqrt(2.0),
                                                                -np.sqrt(2.0)])


def test_samples_whose_closest_point_is_a_tip_edge() -> None:
    # a blade side in the plane x = 0 (z <= 10) and its tip, the plane z = 10 for
    # x in [-2, 0]: they share the edge x = 0, z = 10
    side = np.array([[[0, 0, 0], [0, 10, 0], [0, 0, 10]], [[0, 10, 0], [0, 10, 10], [0, 0, 10]]],
                    dtype=float)
    tip = np.array([[[0, 0, 10], [0, 10, 10], [-2, 0, 10]],
                    [[0, 10, 10], [-2, 10, 10], [-2, 0, 10]]], dtype=float)
    triangles = np.concatenate([side, tip])
    roles = np.array(["suction", "suction", "shroud", "shroud"])
    points = np.array([[0.5, 5.0, 9.0],     # over the side: foot (0, 5, 9)
                       [0.5, 5.0, 9.95],    # still over the side, 0.05 below the edge
                       [0.5, 5.0, 10.3],    # beside the tip's corner: foot on the edge
                       [0.2, 5.0, 10.0]])   # level with the tip: foot on the edge
    role, distance = closest_roles(triangles, roles, points)
    assert distance == pytest.approx([0.5, 0.5, np.hypot(0.5, 0.3), 0.2])
    assert list(role[:2]) == ["suction", "suction"]
    assert list(on_tip_edge(triangles, roles, points, distance)) == [False, False, True, True]


def _flat_design() -> object:
    """A stand-in for ``LabelledDesign``: hub z = 0 and shroud z = 10 (r 0..40), the
    blades' edges at r = 10 and r = 30 on both, no fillet or tip triangles."""
    from types import SimpleNamespace

    hub = np.array([[0.0, 0.0], [0.0, 40.0]])
    shroud = np.array([[10.0, 0.0], [10.0, 40.0]])
    edges_h = np.array([[0.0, 10.0], [0.0, 30.0]])
    edges_s = np.array([[10.0, 10.0], [10.0, 30.0]])
    return SimpleNamespace(
        meridional=(hub, shroud, edges_h, edges_s), triangles=np.zeros((0, 3, 3)),
        roles=np.zeros(0, dtype="<U13"),
        face_roles=np.array(["hub", "pressure", "leading_edge", "back"]),
        face_splitter=np.zeros(4, dtype=bool))


def test_the_verdict_covers_every_milled_face_and_lists_lathe_faces_apart() -> None:
    from cam.run.regions import region_summary
    from cam.verify.deviation import Deviation

    design = _flat_design()
    points = np.array([point(0.1, 20.0), point(0.1, 35.0), point(5.0, 20.0),
                       point(11.0, 20.0), point(5.0, 10.0), point(-0.0, 20.0)])
    faces = np.array([0, 0, 1, 1, 2, 3])  # hub, hub, pressure, pressure, LE, back
    moves = np.array([3, 3, 4, 4, -1, -1])
    signed = np.array([0.1, 1.0, 0.1, 1.5, 0.9, 0.0])

    def summary(signed: np.ndarray) -> dict:
        return region_summary(design, Deviation(points, signed, moves, faces),  # type: ignore[arg-type]
                              0.2, 0.05, 2.0, lathe_allowance=2.0)

    found = summary(signed)
    assert set(found["acceptance"]) == {"hub", "pressure", "leading_edge"}
    assert set(found["lathe"]) == {"hub_outside_blades", "pressure_beyond_shroud", "back"}
    assert found["failed"] == ["leading_edge"] and not found["accepted"]
    assert found["lathe"]["hub_outside_blades"]["within_limit"]  # 1.0 <= 2.05
    assert found["roles"].keys() == found["acceptance"].keys() | found["lathe"].keys()
    finished = signed.copy()
    finished[4] = 0.1
    assert summary(finished)["accepted"]
    short = finished.copy()
    short[5] = -0.2  # the back face, never machined, 0.2 mm inside the design
    result = summary(short)
    assert result["stock_short_samples"] == 1 and result["stock_short_max_mm"] == 0.2
    assert not result["accepted"] and result["failed"] == []


def test_skin_beyond_the_blades_largest_radius_is_lathe_work() -> None:
    """A cut trailing edge on a backswept blade is a milled face, but the blank's outer
    diameter over the blades (turned to their largest radius plus the allowance) is
    lathe skin: samples whose closest face is the edge face but which lie radially beyond
    the blades' largest radius (here 30 mm) are ``trailing_edge_beyond_shroud``."""
    from cam.run.regions import blade_radius, region_summary
    from cam.verify.deviation import Deviation

    design = _flat_design()
    # the edge face: a triangle from r = 29 to r = 30 mm, between hub and shroud
    design.triangles = np.array([[point(1.0, 29.0), point(9.0, 29.5),  # type: ignore[attr-defined]
                                  point(5.0, 30.0)]])
    design.roles = np.array(["trailing_edge"])  # type: ignore[attr-defined]
    design.face_roles = np.array(["trailing_edge"])  # type: ignore[attr-defined]
    design.face_splitter = np.zeros(1, dtype=bool)  # type: ignore[attr-defined]
    assert blade_radius(design) == pytest.approx(30.0)  # type: ignore[arg-type]
    points = np.array([point(5.0, 29.6), point(5.0, 31.5), point(8.0, 32.0)])
    moves = np.array([3, -1, 4])
    signed = np.array([0.3, 1.9, 2.0])
    found = region_summary(design, Deviation(points, signed, moves,  # type: ignore[arg-type]
                                             np.zeros(3, dtype=np.int64)),
                           0.2, 0.05, 2.0, lathe_allowance=2.0)
    assert found["acceptance"]["trailing_edge"]["samples"] == 1
    assert found["failed"] == ["trailing_edge"]  # 0.3 mm on the face itself > 0.25
    assert found["lathe"]["trailing_edge_beyond_shroud"]["samples"] == 2
    assert found["lathe"]["trailing_edge_beyond_shroud"]["within_limit"]
    # without blade triangles nothing is beyond: the radius is infinite
    assert blade_radius(_flat_design()) == np.inf  # type: ignore[arg-type]


def test_the_splitters_faces_are_groups_of_their_own() -> None:
    """Main blades' and splitters' samples of the same role are judged apart: the
    splitter's leading edge fails alone, its pressure side beyond the shroud is lathe
    skin of its own, the hub (one face) is not split."""
    from cam.run.regions import region_summary
    from cam.verify.deviation import Deviation

    design = _flat_design()
    design.face_roles = np.array(["hub", "pressure", "leading_edge", "back",  # type: ignore[attr-defined]
                                  "pressure", "leading_edge"])
    design.face_splitter = np.array([False, False, False, False, True, True])  # type: ignore[attr-defined]
    points = np.array([point(0.1, 20.0), point(5.0, 20.0), point(5.0, 10.0),
                       point(5.0, 20.0, 1.0), point(11.0, 20.0, 1.0), point(5.0, 12.0, 1.0)])
    faces = np.array([0, 1, 2, 4, 4, 5])
    moves = np.array([3, 4, 4, 4, -1, 4])
    signed = np.array([0.1, 0.2, 0.1, 0.15, 1.5, 0.6])
    found = region_summary(design, Deviation(points, signed, moves, faces),  # type: ignore[arg-type]
                           0.2, 0.05, 2.0, lathe_allowance=2.0)
    assert set(found["acceptance"]) == {"hub", "pressure", "leading_edge",
                                        "splitter_pressure", "splitter_leading_edge"}
    assert set(found["lathe"]) == {"splitter_pressure_beyond_shroud"}
    assert {k: t["samples"] for k, t in found["acceptance"].items()} == {
        "hub": 1, "pressure": 1, "leading_edge": 1, "splitter_pressure": 1,
        "splitter_leading_edge": 1}
    assert found["acceptance"]["splitter_leading_edge"]["max_mm"] == pytest.approx(0.6)
    assert found["failed"] == ["splitter_leading_edge"] and not found["accepted"]


@pytest.mark.parametrize("fixture", ["splitter", "nine_blade"])
def test_points_of_each_blade_are_owned_by_it(fixture: str) -> None:
    """Points on every blade's sides, edges' neighbourhood and fillet root (the side
    continued below the hub by the fillet radius) are placed on their own blade."""
    from pathlib import Path

    from cam.run.blade_owner import splitter_points
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    spec = load_spec(Path(__file__).resolve().parents[3] / "fixtures" / "impellers"
                     / fixture / "spec.toml")
    surfaces = build_surfaces(spec)
    rng = np.random.default_rng(28)
    u, v = rng.uniform(0.0, 1.0, 400), rng.uniform(0.0, 1.12, 400)
    side = np.where(rng.uniform(size=400) < 0.5, 1, -1)
    for blades, expected in ((surfaces.blades, False), (surfaces.splitters, True)):
        for blade in blades:
            on = np.where(side[:, None] > 0, blade.side(u, v, 1), blade.side(u, v, -1))
            # 2 mm further out along the camber normal: the fillet's width and more
            out = on + 2.0 * side[:, None] * blade.normal(u, v)
            for points in (on, out):
                assert np.all(splitter_points(surfaces, points) == expected)
    assert bool(surfaces.splitters) == (fixture == "splitter")


def test_skin_above_the_blades_highest_point_is_lathe_work() -> None:
    """A leading edge that is a radial line at the inlet (the splitter fixture's) has
    the blank's flat inlet face over it (turned to the blades' highest point plus the
    allowance), before the shroud contour's inlet end where the envelope test does not
    see it: samples whose closest face is the edge face but which lie above the blades'
    highest point (here z 10.5 mm) and beside the blades (their foot at that height
    farther than the limit from the design) are ``leading_edge_beyond_shroud``; the
    milled stock on the edge's apex (above it, over the edge) stays judged."""
    from cam.run.regions import blade_top, region_summary
    from cam.verify.deviation import DesignDistance, Deviation

    design = _flat_design()
    hub = np.array([[0.0, 0.0], [0.0, 40.0]])
    shroud = np.array([[10.0, 30.0], [2.0, 40.0]])  # starts at the edge's tip
    edges_h = np.array([[10.0, 10.0], [0.0, 40.0]])
    edges_s = np.array([[10.0, 30.0], [2.0, 40.0]])
    design.meridional = (hub, shroud, edges_h, edges_s)  # type: ignore[attr-defined]
    # the edge face: apex z = 10.5 from r = 10 to r = 30
    edge = np.array([point(10.5, 10.0), point(10.5, 30.0), point(10.0, 20.0)])
    design.triangles = edge[None]  # type: ignore[attr-defined]
    design.distance = DesignDistance(edge, np.array([[0, 1, 2]]))  # type: ignore[attr-defined]
    design.roles = np.array(["leading_edge"])  # type: ignore[attr-defined]
    design.face_roles = np.array(["leading_edge"])  # type: ignore[attr-defined]
    assert blade_top(design) == pytest.approx(10.5)  # type: ignore[arg-type]
    points = np.array([point(10.3, 20.0), point(12.4, 20.0, 0.9), point(11.0, 15.0, 0.5),
                       point(10.7, 20.0)])  # the last over the apex
    # the envelope test does not see the skin: inside, beyond the contour's inlet end
    assert np.all(shroud_offset(points[1:], shroud, hub) < 0.0)
    moves = np.array([3, -1, 4, 5])
    signed = np.array([0.3, 4.5, 2.0, 0.2])
    found = region_summary(design, Deviation(points, signed, moves,  # type: ignore[arg-type]
                                             np.zeros(4, dtype=np.int64)),
                           0.2, 0.05, 2.0, lathe_allowance=2.0)
    assert found["acceptance"]["leading_edge"]["samples"] == 2
    assert found["failed"] == ["leading_edge"]  # 0.3 mm on the face itself > 0.25
    assert found["lathe"]["leading_edge_beyond_shroud"]["samples"] == 2
    # without blade triangles nothing is above: the top is infinite
    assert blade_top(_flat_design()) == np.inf  # type: ignore[arg-type]
