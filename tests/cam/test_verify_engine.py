"""The fast dexel engine against the general path it replaces.

* each closed form of ``cam.verify.interval`` against ``kernels.swept_interval`` (the
  accuracy reference, itself tested against sampling in test_verify_volume.py);
* the batched sweep (``cam.verify.sweep``) against the per-primitive reference sweep
  ``kernels.sweep_moves`` that visits every ray of the bounding box and calls
  ``swept_interval`` on each: the same intervals, interval ends and move ids;
* one thread and two give identical stocks and statistics.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.tools import Segment, Tool
from cam.verify.interval import (
    capsule_interval,
    capsule_row,
    endpoint_interval,
    endpoint_row,
    normal_interval,
    normal_row,
    parallel_cylinder_interval,
    stadium_row,
)
from cam.verify.kernels import sweep_moves, swept_interval, tile_bounds
from cam.verify.stock import TILE, Stock
from cam.verify.toolshape import frustum, sphere_cap, tool_shape

#: Interval ends agree to round-off of ~100 mm coordinates.
TOL = 1e-7


def _coefficients(prim: np.ndarray, tip: np.ndarray, move: np.ndarray, axis: np.ndarray,
                  origin: np.ndarray, k: int) -> tuple[float, ...]:
    """Q(t, s) coefficients and height terms of one ray (kernels module doc)."""
    w = origin - tip
    zu, zd, zw = axis[k], axis @ move, axis @ w
    u_p, d_p, w_p = np.eye(3)[k] - zu * axis, move - zd * axis, w - zw * axis
    alpha, beta, gamma = prim[:3]
    return (u_p @ u_p + alpha * zu * zu, -(u_p @ d_p) - alpha * zu * zd,
            d_p @ d_p + alpha * zd * zd,
            w_p @ u_p + alpha * zw * zu + 0.5 * beta * zu,
            -(w_p @ d_p) - alpha * zw * zd - 0.5 * beta * zd,
            w_p @ w_p + alpha * zw * zw + beta * zw + gamma, zw, zu, zd)


def _reference(prim: np.ndarray, coeffs: tuple[float, ...]) -> tuple[float, float]:
    return swept_interval(*coeffs, prim[3], prim[4], np.empty((2, 2)))


def _same(got: tuple[float, float], want: tuple[float, float]) -> None:
    """Equal intervals, or both empty (a sliver below TOL counts as empty)."""
    g_empty = not got[1] - got[0] > TOL
    w_empty = not want[1] - want[0] > TOL
    if g_empty or w_empty:
        assert g_empty and w_empty, (got, want)
        return
    assert got[0] == pytest.approx(want[0], abs=TOL)
    assert got[1] == pytest.approx(want[1], abs=TOL)


def _random_case(seed: int, short: bool) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    tip = rng.uniform(-3.0, 3.0, 3)
    move = rng.normal(size=3)
    move *= (rng.uniform(1e-4, 0.05) if short else rng.uniform(0.0, 6.0)) / np.linalg.norm(move)
    k = int(rng.integers(3))
    origin = tip + rng.uniform(-4.0, 4.0, 3) + rng.uniform(0.0, 8.0) * axis
    origin[k] = 0.0
    return axis, tip, move, origin, np.array([k])


PRIMITIVES = {
    "ball": sphere_cap(2.0, 2.0, 0.0, 4.0),
    "hemisphere": sphere_cap(2.0, 2.0, 0.0, 2.0),
    "cylinder": frustum(2.0, 9.0, 2.0, 2.0),
    "cone": frustum(2.0, 7.0, 1.0, 3.0),
    "neck": frustum(9.0, 20.0, 2.0, 1.5),
}


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 10**6), short=st.booleans())
def test_capsule_is_the_swept_ball(seed: int, short: bool) -> None:
    prim = PRIMITIVES["ball"]
    axis, tip, move, origin, kk = _random_case(seed, short)
    k = int(kk[0])
    coeffs = _coefficients(prim, tip, move, axis, origin, k)
    centre = tip + 2.0 * axis
    m = origin - centre
    ia, ja = (k + 1) % 3, (k + 2) % 3
    length = float(np.linalg.norm(move))
    u = move / length if length > 0 else np.zeros(3)
    got = capsule_interval(m[ia], m[ja], m[k], u[ia], u[ja], u[k], length, 4.0)
    _same(got, _reference(prim, coeffs))
    # the vectorised row form gives the same numbers
    ta, tb = np.empty(3), np.empty(3)
    capsule_row(ta, tb, 3, m[ia], m[ja] - 0.1, 0.1, m[k], u[ia], u[ja], u[k], length, 4.0)
    _same((ta[1], tb[1]), got)


@settings(max_examples=400, deadline=None)
@given(seed=st.integers(0, 10**6), short=st.booleans(),
       kind=st.sampled_from(sorted(PRIMITIVES)))
def test_end_pose_interval_matches_the_general_path(seed: int, short: bool, kind: str) -> None:
    prim = PRIMITIVES[kind]
    axis, tip, move, origin, kk = _random_case(seed, short)
    coeffs = _coefficients(prim, tip, move, axis, origin, int(kk[0]))
    qa = coeffs[0]
    if not qa > 1e-9:
        return
    ok, ta, tb = endpoint_interval(*coeffs, prim[3], prim[4])
    if ok:
        _same((ta, tb), _reference(prim, coeffs))
    if abs(coeffs[7]) > 1e-14:  # the vectorised row form (zu != 0) says the same
        ok, ta, tb = _row_form(endpoint_row, prim, tip, move, axis, origin, int(kk[0]))
        if ok:
            _same((ta, tb), _reference(prim, coeffs))


def _row_form(row_kernel, prim: np.ndarray, tip: np.ndarray, move: np.ndarray,  # type: ignore[no-untyped-def]
              axis: np.ndarray, origin: np.ndarray, k: int) -> tuple[bool, float, float]:
    """The row kernel's interval of one ray (the third ray of a row of five)."""
    ia, ja = (k + 1) % 3, (k + 2) % 3
    g = [ia, ja, k]
    ag, dg = axis[g], move[g]
    zu, zd = axis[k], float(axis @ move)
    uu, ud = 1.0 - zu * zu, dg[2] - zu * zd
    dd = float(dg @ dg) - zd * zd
    alpha = prim[0]
    out_a, out_b, out_ok = np.zeros(5), np.zeros(5), np.zeros(5, np.bool_)
    h = 0.1
    rays = np.array([3, 2, 1], np.int64)  # the row's rays 1..3, in any order
    row_kernel(out_a, out_b, out_ok, rays, 3, origin[ja] - 2 * h, 1, h, origin[ia] - tip[ia],
               tip[ja], -tip[k], ag[0], ag[1], ag[2], dg[0], dg[1], dg[2], zu, zd, prim[0],
               prim[1], prim[2], uu + alpha * zu * zu, -ud - alpha * zu * zd,
               dd + alpha * zd * zd, prim[3], prim[4])
    return bool(out_ok[1]), float(out_a[1]), float(out_b[1])


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 10**6), short=st.booleans(), k=st.integers(0, 2),
       sign=st.sampled_from([-1.0, 1.0]))
def test_ray_along_a_cylinder_axis(seed: int, short: bool, k: int, sign: float) -> None:
    prim = PRIMITIVES["cylinder"]
    rng = np.random.default_rng(seed)
    axis = sign * np.eye(3)[k]
    tip = rng.uniform(-3.0, 3.0, 3)
    move = rng.normal(size=3)
    move *= (rng.uniform(1e-4, 0.05) if short else rng.uniform(0.0, 6.0)) / np.linalg.norm(move)
    origin = tip + rng.uniform(-3.0, 3.0, 3)
    origin[k] = 0.0
    qa, qb, qc, qd, qe, qf, zw, zu, zd = _coefficients(prim, tip, move, axis, origin, k)
    assert abs(qa) < 1e-12 and abs(qb) < 1e-12 and abs(qd) < 1e-12
    got = parallel_cylinder_interval(qc, qe, qf, zw, zu, zd, prim[3], prim[4])
    _same(got, _reference(prim, (qa, qb, qc, qd, qe, qf, zw, zu, zd)))


@settings(max_examples=500, deadline=None)
@given(seed=st.integers(0, 10**6), short=st.booleans(),
       kind=st.sampled_from(sorted(PRIMITIVES)),
       move_kind=st.sampled_from(["any", "along_ray", "along_axis", "normal_plane"]))
def test_ray_normal_to_the_axis(seed: int, short: bool, kind: str, move_kind: str) -> None:
    prim = PRIMITIVES[kind]
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3))
    axis = rng.normal(size=3)
    if rng.random() < 0.5:
        axis[(k + 1 + int(rng.integers(2))) % 3] = 0.0  # a world axis or a plane of two
    axis[k] = 0.0
    axis /= np.linalg.norm(axis)
    tip = rng.uniform(-3.0, 3.0, 3)
    move = {"any": rng.normal(size=3), "along_ray": np.eye(3)[k], "along_axis": axis,
            "normal_plane": np.eye(3)[k] + rng.normal() * np.cross(axis, np.eye(3)[k])}[
                move_kind]
    move = move * (rng.uniform(1e-4, 0.05) if short else rng.uniform(0.0, 6.0)) / np.linalg.norm(
        move)
    origin = tip + rng.uniform(-4.0, 4.0, 3) + rng.uniform(0.0, 8.0) * axis
    origin[k] = 0.0
    coeffs = _coefficients(prim, tip, move, axis, origin, k)
    qa, qb, qc, qd, qe, qf, zw, zu, zd = coeffs
    assert zu == 0.0
    ok, ta, tb = normal_interval(qa, qb, qc, qd, qe, qf, zw, zd, prim[3], prim[4], prim[0])
    assert ok or prim[0] < 0.0  # only a cone may need the general path
    if ok:
        _same((ta, tb), _reference(prim, coeffs))
    row_ok, row_a, row_b = _row_form(normal_row, prim, tip, move, axis, origin, k)
    assert row_ok == ok
    if row_ok:
        _same((row_a, row_b), (ta, tb))


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_stadium_row_is_the_span_within_reach(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p0, p1 = rng.uniform(-5, 5, 2), rng.uniform(-5, 5, 2)
    if rng.random() < 0.3:
        p1[int(rng.integers(2))] = p0[int(rng.integers(2))]  # axis-parallel segments
    rho = rng.uniform(0.1, 3.0)
    x = rng.uniform(-8, 8)
    ylo, yhi = stadium_row(x, p0[0], p0[1], p1[0], p1[1], rho)
    y = np.linspace(-12, 12, 24001)
    v = p1 - p0
    t = np.clip(((x - p0[0]) * v[0] + (y - p0[1]) * v[1]) / max(v @ v, 1e-300), 0, 1)
    dist = np.hypot(x - p0[0] - t * v[0], y - p0[1] - t * v[1])
    inside = y[dist <= rho]
    if len(inside) == 0:
        assert not yhi - ylo > 2e-3
        return
    assert ylo <= inside.min() + 1e-9 and yhi >= inside.max() - 1e-9
    assert ylo == pytest.approx(inside.min(), abs=2e-3)
    assert yhi == pytest.approx(inside.max(), abs=2e-3)


# ---------------------------------------------------------------------- whole sweeps
def _tool(kind: str) -> Tool:
    corner = {"ball": 2.0, "flat": 0.0, "bull": 1.0}[kind]
    return Tool(name=kind, number=1, shape=kind if kind != "bull" else "bullnose",
                diameter=4.0, corner_radius=corner, flute_length=6.0, shank_diameter=4.0,
                stickout=9.0, holder=(Segment("holder", 9.0, 16.0, 6.0, 8.0),))


def _moves(seed: int, n: int, five_axis: bool) -> tuple[np.ndarray, ...]:
    """A random walk of the tip through and over a 20 x 16 x 8 mm box."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(n, 3)) * np.array([1.5, 1.5, 0.6])
    steps[rng.random(n) < 0.5] *= 0.02  # short sub-moves as a turning block makes
    tips = np.cumsum(np.vstack([[-6.0, -4.0, -1.0], steps]), axis=0)
    tips[:, 2] = np.clip(tips[:, 2], -4.0, 3.0)
    if five_axis:
        tilt = np.cumsum(rng.normal(size=(n, 2)) * 0.05, axis=0)
        axes = np.column_stack([np.sin(tilt[:, 0]), np.sin(tilt[:, 1]), np.ones(n)])
        axes /= np.linalg.norm(axes, axis=1)[:, None]
    else:
        axes = np.tile([0.0, 0.0, 1.0], (n, 1))
    return tips[:-1], np.diff(tips, axis=0), axes


def _reference_sweep(stock: Stock, tips, moves, axes, shape, masks=None) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The per-primitive sweep over every ray of the bounding box (kernels.sweep_moves);
    ``masks``: the primitives of each move (default all)."""
    prims = np.ascontiguousarray(np.vstack([shape.cutter, shape.body]))
    if masks is None:
        masks = np.full(len(tips), (1 << len(prims)) - 1, np.int64)
    cuts = np.zeros(len(prims), np.bool_)
    cuts[: len(shape.cutter)] = True
    strides = np.ones(len(prims), np.int64)
    strides[len(shape.cutter):] = max(1, round(0.5 / stock.pitch))
    ids = np.arange(len(tips), dtype=np.int32)
    longest = np.zeros(len(tips))
    for grid in stock.grids:
        stats = np.zeros((len(tips), 4))
        t_lo, t_hi = tile_bounds(grid.lo, grid.hi, grid.start, grid.count, grid.shape, TILE)
        first = 0
        while True:
            failed = sweep_moves(
                grid.lo, grid.hi, grid.lo_move, grid.hi_move, grid.start, grid.count,
                grid.cap, grid.used, grid.k, grid.origin, grid.shape, grid.pitch,
                t_lo, t_hi, TILE, tips, moves, axes, ids, prims, cuts, strides, masks, first, stats)
            if failed < 0:
                break
            grid.grow()
            first = failed
        longest = np.maximum(longest, stats[:, 3])
    return longest


def _ends_at(cutter: np.ndarray, tip: np.ndarray, move: np.ndarray, axis: np.ndarray,
             origin: np.ndarray, k: int, t: float) -> bool:
    """True when the cutter swept along ``move`` has an interval end at ``t`` on the ray
    through ``origin`` along axis ``k``, or its interval there covers ``t`` to within
    round-off of an end of the union of its primitives."""
    lo, hi = math.inf, -math.inf
    for prim in cutter:
        a, b = _reference(prim, _coefficients(prim, tip, move, axis, origin, k))
        if b > a:
            lo, hi = min(lo, a), max(hi, b)
    return bool(abs(lo - t) < 1e-6 or abs(hi - t) < 1e-6)


def _intervals(stock: Stock) -> list[tuple[np.ndarray, ...]]:
    out = []
    for grid in stock.grids:
        slot, rays = grid.slots()
        out.append((rays, grid.lo[slot], grid.hi[slot], grid.lo_move[slot], grid.hi_move[slot]))
    return out


@pytest.mark.parametrize(("kind", "five_axis", "seed"), [
    ("ball", False, 1), ("ball", True, 2), ("flat", False, 3), ("flat", True, 4),
    ("bull", True, 5),
])
def test_sweep_matches_the_reference_sweep(kind: str, five_axis: bool, seed: int) -> None:
    shape = tool_shape(_tool(kind))
    tips, moves, axes = _moves(seed, 120, five_axis)
    fast = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    slow = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    stats = fast.sweep(tips, moves, axes, np.arange(len(tips), dtype=np.int32), shape)
    ref_overlap = _reference_sweep(slow, tips, moves, axes, shape)
    assert fast.volume() == pytest.approx(slow.volume(), rel=1e-9)
    grid_points = [g.ray_points(np.arange(len(g.count))) for g in fast.grids]
    grid_index = 0
    for got, want in zip(_intervals(fast), _intervals(slow), strict=True):
        assert np.array_equal(got[0], want[0])  # the same intervals on the same rays
        np.testing.assert_allclose(got[1], want[1], atol=TOL)
        np.testing.assert_allclose(got[2], want[2], atol=TOL)
        # the move that made each end; where two moves leave the same end (the next
        # one starts where the last one stopped, its sweep ends there too) the
        # round-off decides which one trims last: then the end must lie on the
        # boundary of both moves' sweeps
        for ends, where in ((3, got[1]), (4, got[2])):
            for i in np.flatnonzero(got[ends] != want[ends]):
                point = grid_points[grid_index][int(got[0][i])].copy()
                for move in (got[ends][i], want[ends][i]):
                    assert move >= 0
                    assert _ends_at(shape.cutter, tips[move], moves[move], axes[move], point,
                                    grid_index, where[i])
        grid_index += 1
    np.testing.assert_allclose(stats[:, 2], ref_overlap, atol=TOL)
    assert stats[:, 0].sum() > 0.0


def test_one_thread_and_two_give_identical_results() -> None:
    shape = tool_shape(_tool("ball"))
    tips, moves, axes = _moves(7, 300, True)
    results = []
    for threads in (1, 2):
        stock = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.1)
        stock.threads = threads
        stats = stock.sweep(tips, moves, axes, np.arange(len(tips), dtype=np.int32), shape)
        results.append((stats, _intervals(stock)))
    (s1, g1), (s2, g2) = results
    assert np.array_equal(s1, s2)
    for a, b in zip(g1, g2, strict=True):
        for x, y in zip(a, b, strict=True):
            assert np.array_equal(x, y)


def test_grids_through_batches_on_threads_give_the_one_call_result() -> None:
    """``Stock.sweep(batch=...)`` (``cam.verify.schedule``: each grid a chain of batches,
    the grids in any order on the pool): the same stock and statistics with one, two
    and three threads, and the stock of one call per grid (its statistics to
    round-off: a pool overflow splits a move's sum at another place); the progress
    reaches every move; a pool overflow in a batch (rows of holes split the X rays)
    resumes."""
    shape = tool_shape(_tool("bull"))
    tips, moves, axes = _moves(11, 240, True)
    xs, ys = np.meshgrid([-7.45, -2.45, 2.55, 7.55], [-5.05, 0.05, 5.05])
    holes = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 1.0)])
    tips = np.vstack([holes, tips])
    moves = np.vstack([np.tile([0.0, 0.0, -5.0], (xs.size, 1)), moves])
    axes = np.vstack([np.tile([0.0, 0.0, 1.0], (xs.size, 1)), axes])
    ids = np.arange(len(tips), dtype=np.int32) // 3  # several sub-moves a block
    whole = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    whole.threads = 1
    one_call = whole.sweep(tips, moves, axes, ids, shape)
    results = []
    for threads in (1, 2, 3):
        stock = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
        stock.threads = threads
        size = len(stock.grids[0].lo)
        seen: list[int] = []
        stats = stock.sweep(tips, moves, axes, ids, shape, batch=37, done=seen.append)
        assert len(stock.grids[0].lo) > size  # the X grid's pool grew
        assert seen == sorted(set(seen)) and seen[-1] == len(tips)
        results.append((stats, _intervals(stock)))
    for stats, intervals in results:
        assert np.array_equal(stats, results[0][0])
        np.testing.assert_allclose(stats, one_call, rtol=1e-12, atol=1e-12)
        for a, b in zip(intervals, _intervals(whole), strict=True):
            for x, y in zip(a, b, strict=True):
                assert np.array_equal(x, y)


def test_longest_cut_is_the_cutters_cut_along_one_ray() -> None:
    # a 4 mm ball plunged 2 mm into a box: along a Z ray it cuts 2 mm; the longest
    # cut is the chord of the X (and Y) ray 0.05 mm below the top through the ball
    # centre's path (the ray centres are 0.05 mm off the top face)
    shape = tool_shape(_tool("ball"))
    stock = Stock.box([-5.0, -5.0, -5.0], [5.0, 5.0, 0.0], 0.1)
    before = stock.volume()
    stats = stock.sweep(np.array([[0.05, 0.05, 0.0]]), np.array([[0.0, 0.0, -2.0]]),
                        np.array([[0.0, 0.0, 1.0]]), np.zeros(1, np.int32), shape)
    assert stats[0, 1] == pytest.approx(2.0 * math.sqrt(4.0 - 0.05**2), abs=1e-9)
    # removed: the lower half of the ball (its centre ends on the top face)
    exact = 2.0 / 3.0 * math.pi * 8.0
    assert stats[0, 0] == pytest.approx(before - stock.volume(), rel=1e-12)
    assert stats[0, 0] == pytest.approx(exact, rel=5e-3)


def test_a_pool_overflow_resumes_where_it_stopped() -> None:
    # rows of 32 holes split the X rays through them 32 times: the pool overflows in
    # the middle of a band of rows and grows; the result is the reference sweep's
    shape = tool_shape(Tool(name="drill", number=1, shape="flat", diameter=0.4,
                            corner_radius=0.0, flute_length=6.0, shank_diameter=0.4,
                            stickout=9.0))
    # (centres 0.05 mm off the rays: no ray grazes a hole, where round-off decides)
    xs, ys = np.meshgrid(np.linspace(-9.25, 9.35, 32), [-6.05, -3.05, 0.05, 3.05, 6.05])
    tips = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 1.0)])
    moves = np.tile([0.0, 0.0, -5.0], (xs.size, 1))
    axes = np.tile([0.0, 0.0, 1.0], (xs.size, 1))
    fast = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    slow = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    size = len(fast.grids[0].lo)
    fast.sweep(tips, moves, axes, np.arange(len(tips), dtype=np.int32), shape)
    assert len(fast.grids[0].lo) > size  # the X grid's pool grew
    _reference_sweep(slow, tips, moves, axes, shape)
    for got, want in zip(_intervals(fast), _intervals(slow), strict=True):
        assert np.array_equal(got[0], want[0])
        np.testing.assert_allclose(got[1], want[1], atol=TOL)
        np.testing.assert_allclose(got[2], want[2], atol=TOL)
        assert np.array_equal(got[3], want[3]) and np.array_equal(got[4], want[4])


def test_moves_of_part_of_the_tool_match_the_reference_sweep() -> None:
    """``Stock.sweep(parts=...)``: moves that sweep only level 1 (here the ball), only
    level 0 (the rest), or both give the reference sweep's intervals with the same
    primitive masks."""
    shape = dataclasses.replace(tool_shape(_tool("ball")),
                                cutter_level=np.array([1, 0], np.int8), level_reach=(4.0,))
    tips, moves, axes = _moves(7, 120, True)
    parts = np.random.default_rng(7).integers(1, 4, len(tips)).astype(np.int8)
    whole = (1 << (len(shape.cutter) + len(shape.body))) - 1
    masks = np.where(parts == 2, 1, np.where(parts == 1, whole & ~1, whole)).astype(np.int64)
    fast = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    slow = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    plain = Stock.box([-10.0, -8.0, -8.0], [10.0, 8.0, 0.0], 0.2)
    ids = np.arange(len(tips), dtype=np.int32)
    stats = fast.sweep(tips, moves, axes, ids, shape, parts=parts)
    ref_overlap = _reference_sweep(slow, tips, moves, axes, shape, masks)
    plain.sweep(tips, moves, axes, ids, shape)
    assert fast.volume() == pytest.approx(slow.volume(), rel=1e-9)
    assert fast.volume() > plain.volume()  # the parts left out really were left out
    for got, want in zip(_intervals(fast), _intervals(slow), strict=True):
        assert np.array_equal(got[0], want[0])
        np.testing.assert_allclose(got[1], want[1], atol=TOL)
        np.testing.assert_allclose(got[2], want[2], atol=TOL)
    np.testing.assert_allclose(stats[:, 2], ref_overlap, atol=TOL)
