"""The exact distance kernel (``gjk``, ``body_distance``, ``clearance``) against fcl.

python-fcl is the oracle: the kernel's distances between the scene's triangles and
the posed tool meshes agree with ``fcl.distance`` to rounding, its "clear" answers
never hide an fcl contact, and ``CollisionScene`` answers on the postures of real
finishing runs (nine_blade and splitter, test settings) are those of the plain fcl
loop: hit/miss, part and role identical, clearances within 1e-9 mm below the cap
and a valid lower bound above it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import fcl
import numpy as np
import pytest

from cam.collision import CollisionScene, plain_fcl_check, rotations_to
from cam.collision.body_distance import body_distances, tool_pieces
from cam.collision.clearance import BAND
from cam.collision.gjk import CYLINDER, POINTS, gjk_interval, section_ring, triangle_piece_distance
from cam.collision.synthetic import impeller_meshes
from cam.collision.tool_mesh import revolve
from cam.finishing.options import FinishOptions
from cam.finishing.plan import plan_finishing
from cam.finishing.scene import surface_meshes
from cam.tools import resolve_tool
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
TOOL = resolve_tool("ball6_taper")
#: Agreement of the kernel's distances with fcl's, mm.
AGREE = 1e-9


@pytest.fixture(scope="module")
def scene() -> CollisionScene:
    return CollisionScene(impeller_meshes(blades=5))


def _random_postures(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    radius = rng.uniform(10.0, 45.0, n)
    phi = rng.uniform(0.0, 2 * math.pi, n)
    tip = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), rng.uniform(5, 60, n)])
    axis = rng.normal(size=(n, 3)) + [0.0, 0.0, 1.5]
    return tip, axis / np.linalg.norm(axis, axis=1)[:, None]


def test_flat_pieces_are_dropped_only_when_a_ring_covers_them() -> None:
    # ball6_taper's shank and holder: the taper, the holder cone and cylinder; the
    # discs and the shoulder annulus lie in them
    model = CollisionScene({"floor": revolve(np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]),
                                             8)}).tool_model(TOOL)
    pieces = model.clear_pieces.pieces
    assert len(pieces) == 3 and np.all(pieces[:, 3] > pieces[:, 1])
    # a flange wider than the ring below it stays
    flange = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [4.0, 1.0], [0.0, 1.0]])
    kept = tool_pieces([flange], 1.0)
    assert [tuple(p) for p in kept] == [(2.0, 0.0, 2.0, 1.0), (2.0, 1.0, 4.0, 1.0),
                                        (4.0, 1.0, 0.0, 1.0)]


def test_triangle_piece_distance_by_hand() -> None:
    # a cylinder of circumradius 2 (4 sections: vertices on the axes), z 0..10, and a
    # triangle in the plane x = 5: distance 3 to the vertex ring at (2, 0)
    tri = np.array([[5.0, -1.0, 2.0], [5.0, 1.0, 2.0], [5.0, 0.0, 8.0]])
    square = section_ring(4)
    lo, hi = triangle_piece_distance(tri, 2.0, 0.0, 2.0, 10.0, square, np.inf, np.empty((4, 3)),
                                     1.0, 0.0, 0.0)
    assert lo == pytest.approx(3.0, abs=1e-12) and hi == pytest.approx(3.0, abs=1e-12)
    # rotated by 45 deg about z the flat side faces it: distance 5 - 2 cos(45 deg)
    c = math.cos(math.pi / 4)
    turned = tri @ np.array([[c, c, 0.0], [-c, c, 0.0], [0.0, 0.0, 1.0]])
    lo, hi = triangle_piece_distance(turned, 2.0, 0.0, 2.0, 10.0, square, np.inf,
                                     np.empty((4, 3)), 0.0, 1.0, 0.0)
    assert hi == pytest.approx(5.0 - 2.0 * c, abs=1e-12) and hi - lo < 1e-9
    # crossing the cylinder: overlap
    inside = tri - [4.0, 0.0, 0.0]
    assert triangle_piece_distance(inside, 2.0, 0.0, 2.0, 10.0, square, np.inf,
                                   np.empty((4, 3)), 1.0, 0.0, 0.0) == (0.0, 0.0)


def test_gjk_interval_of_placed_shapes_by_hand() -> None:
    """The machine's use: an exact cylinder (radius 1, half-length 2, axis z) at the
    origin and a unit cube turned 90 deg about z and moved to x = 5: 3.5 apart; the
    stop rule's ``stop_below`` ends it at the first support."""
    cube = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5)
                     for z in (-0.5, 0.5)])
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    no_params = (0.0,) * 8
    box = (POINTS, cube, 0, 8, no_params, turn, np.array([5.0, 0.0, 1.0]))
    cylinder = (CYLINDER, np.zeros((1, 3)), 0, 0, (0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 2.0),
                np.eye(3), np.zeros(3))
    direction = np.array([1.0, 1.0, 0.0])
    lo, hi = gjk_interval(box, cylinder, direction, np.inf, -np.inf, 1e-9, 64,
                          np.empty((4, 3)))
    assert lo == pytest.approx(3.5, abs=1e-9) and hi == pytest.approx(3.5, abs=1e-9)
    assert direction[0] > 0.0 and abs(direction[2]) < 1e-9  # the last direction, B to A
    lo, hi = gjk_interval(box, cylinder, np.zeros(3), np.inf, 10.0, 1e-9, 64,
                          np.empty((4, 3)))
    assert 0.0 <= lo <= 3.5 <= hi <= 10.0


@pytest.mark.parametrize("part", ["cutter", "body"])
def test_kernel_distances_equal_fcl(scene: CollisionScene, part: str) -> None:
    tip, axis = _random_postures(21, 300)
    rot = rotations_to(axis)
    model = scene.tool_model(TOOL, -0.05)
    if part == "body":
        shape, obj = model.clear_pieces, model.clear_object
    else:
        shape, obj = model.pieces["cutter"], model.objects["cutter"]
    assert obj is not None
    roots = np.broadcast_to(scene.arrays.roots, (len(tip), len(scene.roles)))
    lower, upper = body_distances(scene.arrays.forest, roots, tip, rot, shape,
                                  scene.sections, math.inf)
    exact = np.empty(len(tip))
    request = fcl.DistanceRequest()
    for i in range(len(tip)):
        obj.setTransform(fcl.Transform(rot[i], tip[i]))
        exact[i] = max(fcl.distance(obj, scene.whole_object, request, fcl.DistanceResult()), 0)
    apart = lower > BAND
    assert apart.sum() > 50 and (~apart).sum() > 10  # both kinds occur
    assert np.all(upper - lower <= 1e-8)
    assert np.max(np.abs(upper[apart] - exact[apart])) <= AGREE
    # overlapping solids where fcl finds the surfaces 0 apart (no buried triangles here)
    assert np.array_equal(~apart, exact <= BAND)


def test_capped_kernel_is_a_lower_bound_above_the_cap(scene: CollisionScene) -> None:
    tip, axis = _random_postures(22, 200)
    rot = rotations_to(axis)
    model = scene.tool_model(TOOL)
    roots = np.broadcast_to(scene.arrays.roots, (len(tip), len(scene.roles)))
    full = body_distances(scene.arrays.forest, roots, tip, rot, model.clear_pieces,
                          scene.sections, math.inf)[1]
    lower, upper = body_distances(scene.arrays.forest, roots, tip, rot, model.clear_pieces,
                                  scene.sections, 2.0)
    below = full < 2.0
    assert below.any() and (~below).any()
    assert np.allclose(upper[below], full[below], atol=AGREE)
    assert np.all(np.isinf(upper[~below])) and np.all(lower[~below] >= 2.0 - AGREE)


#: Of each operation's passes, every this many is planned (``_finishing_postures``).
PASS_STRIDE = 3


class EveryFewPasses:
    """``plan_finishing``'s ``keep``: all of every ``PASS_STRIDE``-th pass of each
    operation (counted in planning order), none of the others."""

    def __init__(self) -> None:
        self.seen: dict[str, int] = {}

    def __call__(self, path: Any) -> np.ndarray | None:
        index = self.seen[path.operation] = self.seen.get(path.operation, -1) + 1
        return None if index % PASS_STRIDE == 0 else np.zeros(len(path.centre), bool)

    def region(self, piece: Any) -> int:
        return -1  # passes are kept whole: no piece has a region of its own


def _finishing_postures(name: str, tool: str, options: dict[str, float]
                        ) -> tuple[CollisionScene, list[tuple[np.ndarray, np.ndarray, dict]]]:
    """The scene and every ``check_postures`` call of one passage's finishing, every
    ``PASS_STRIDE``-th pass of each operation planned (the others left out through
    ``plan_finishing``'s ``keep``): the postures of every operation, from the hub to
    the tip, at a third of the planning's cost (the test samples 150 of them)."""
    surfaces = build_surfaces(load_spec(ROOT / "fixtures" / "impellers" / name / "spec.toml"))
    scene = CollisionScene(surface_meshes(surfaces, 1.0))
    calls: list[tuple[np.ndarray, np.ndarray, dict]] = []
    check = scene.check_postures

    def record(tool_: object, tip: np.ndarray, axis: np.ndarray, **kw: object) -> object:
        calls.append((np.asarray(tip).copy(), np.asarray(axis).copy(), dict(kw)))
        return check(tool_, tip, axis, **kw)  # type: ignore[arg-type]

    scene.check_postures = record  # type: ignore[method-assign, assignment]
    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml"))
    with pytest.MonkeyPatch.context() as patch:  # planned here, where the calls are seen
        patch.setenv("IMPELLER_CAM_THREADS", "1")
        plan_finishing(surfaces, resolve_tool(tool), kins, scene,
                       FinishOptions.from_mapping(dict(options, passages=1)),
                       scene_source="surfaces", keep=EveryFewPasses())
    scene.check_postures = check  # type: ignore[method-assign]
    return scene, calls


@pytest.mark.parametrize("name, tool, options", [
    ("nine_blade", "ball6_taper", dict(scallop_mm=2.5, point_spacing_mm=2.0,
                                       clearance_mm=2.5, clearance_exact_mm=3.0)),
    pytest.param("splitter", "ball4_taper", dict(scallop_mm=1.5, point_spacing_mm=2.0,
                                                 clearance_mm=2.5, clearance_exact_mm=3.0),
                 marks=pytest.mark.slow),  # about 12 s of a core
])
def test_finishing_postures_answer_like_the_plain_fcl_loop(
        name: str, tool: str, options: dict[str, float]) -> None:
    """Postures a finishing run checked (seeded sample of 150, chain-like clearance
    2.5 mm): the same hit/miss, part and role as the plain loop; clearance within
    1e-9 mm of fcl's below the cap, at least the cap above it."""
    scene, calls = _finishing_postures(name, tool, options)
    tip = np.concatenate([c[0] for c in calls])
    axis = np.concatenate([c[1] for c in calls])
    kw = calls[0][2]
    rng = np.random.default_rng(5)
    pick = rng.choice(len(tip), size=min(150, len(tip)), replace=False)
    the_tool = resolve_tool(tool)
    allowance = float(kw["cutter_allowance"])  # type: ignore[arg-type]
    fast = scene.check_postures(the_tool, tip[pick], axis[pick], cutter_allowance=allowance,
                                clearance_cap=3.0, clearance_limits=(2.5,))
    plain = plain_fcl_check(scene, the_tool, tip[pick], axis[pick],
                            cutter_allowance=allowance)
    assert np.array_equal(fast.collides, plain.collides)
    assert np.array_equal(fast.part, plain.part)
    assert fast.hit_role == plain.hit_role
    below = plain.clearance < 3.0
    assert below.any()
    assert np.max(np.abs(fast.clearance[below] - plain.clearance[below])) <= AGREE
    assert np.all(fast.clearance[~below] >= 3.0 - AGREE)
    assert np.array_equal(fast.clearance < 2.5, plain.clearance < 2.5)
