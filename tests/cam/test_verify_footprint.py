"""The footprint bounds of the sweep (``cam.verify.footprint``) against sampled points.

Every bound must contain every point of what it bounds (a ray it drops is never
looked at again): points of the swept primitive for ``box_side``, points of the
capsule over a rectangle for ``capsule_range``; and the grid's kept summaries
(``dexel.SweepIndex``) must equal a fresh build after a sweep.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.tools import Tool
from cam.verify.dexel import TILE, material_range
from cam.verify.footprint import box_side, capsule_range
from cam.verify.kernels import tile_bounds
from cam.verify.stock import Stock
from cam.verify.toolshape import tool_shape


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_box_side_holds_the_swept_cylinder(seed: int) -> None:
    rng = np.random.default_rng(seed)
    axis = _unit(rng)
    tip = rng.uniform(-20.0, 20.0, 3)
    move = rng.uniform(-5.0, 5.0, 3) * rng.choice([0.0, 1e-3, 1.0])
    zlo = rng.uniform(-2.0, 10.0)
    zhi = zlo + rng.uniform(0.0, 20.0)
    rmax = rng.uniform(0.1, 10.0)
    # points of the cylinder of radius rmax between zlo and zhi, moved along the move
    n = 2000
    e1 = np.cross(axis, _unit(rng))
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    ang = rng.uniform(0.0, 2.0 * np.pi, n)
    rad = rmax * np.sqrt(rng.uniform(0.0, 1.0, n))
    rad[: n // 2] = rmax  # half on the mantle
    z = rng.uniform(zlo, zhi, n)
    z[:100] = zlo
    z[100:200] = zhi
    s = rng.uniform(0.0, 1.0, n)
    s[:50] = 0.0
    s[50:100] = 1.0
    pts = (tip + s[:, None] * move + z[:, None] * axis
           + (rad * np.cos(ang))[:, None] * e1 + (rad * np.sin(ang))[:, None] * e2)
    for c in range(3):
        lo, hi = box_side(tip[c], move[c], axis[c], zlo, zhi, rmax)
        assert pts[:, c].min() >= lo - 1e-9
        assert pts[:, c].max() <= hi + 1e-9


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_capsule_range_holds_the_capsule_over_a_rectangle(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p0 = rng.uniform(-10.0, 10.0, 3)
    u = _unit(rng)
    if rng.uniform() < 0.2:  # along a grid axis: the clip's division by zero
        u = np.eye(3)[rng.integers(3)] * rng.choice([-1.0, 1.0])
    length = rng.uniform(0.0, 25.0) * rng.choice([0.0, 1.0, 1.0])
    rho = rng.uniform(0.05, 6.0)
    xa = rng.uniform(-15.0, 15.0)
    xb = xa + rng.uniform(0.0, 4.0) * rng.choice([0.0, 1.0])
    ya = rng.uniform(-15.0, 15.0)
    yb = ya + rng.uniform(0.0, 4.0)
    klo, khi = capsule_range(xa, xb, ya, yb, p0[0], p0[1], p0[2], u[0], u[1], u[2],
                             length, rho, -np.inf, np.inf)
    # capsule points whose projection lies in the rectangle: aim at it
    n = 5000
    q = np.column_stack([rng.uniform(xa, xb, n), rng.uniform(ya, yb, n), np.zeros(n)])
    s = np.clip(rng.uniform(-0.1, 1.1, n), 0.0, 1.0) * length
    foot = p0 + s[:, None] * u
    dxy = q[:, :2] - foot[:, :2]
    d2 = np.sum(dxy * dxy, axis=1)
    inside = d2 <= rho * rho
    half = np.sqrt(np.maximum(rho * rho - d2, 0.0))
    z_top = foot[:, 2] + half
    z_bot = foot[:, 2] - half
    if not inside.any():
        return
    assert klo <= khi
    assert z_bot[inside].min() >= klo - 1e-9
    assert z_top[inside].max() <= khi + 1e-9


def test_the_kept_summaries_equal_a_fresh_build_after_a_sweep() -> None:
    tool = Tool(name="ball6", number=1, shape="ball", diameter=6.0, corner_radius=3.0,
                flute_length=12.0, shank_diameter=6.0, stickout=12.0)
    shape = tool_shape(tool)
    stock = Stock.box([-15.0, -12.0, -10.0], [15.0, 12.0, 0.0], 0.2)
    rng = np.random.default_rng(7)
    tips = np.cumsum(rng.uniform(-1.5, 1.5, (60, 3)), axis=0) * [1.0, 1.0, 0.2]
    tips[:, 2] -= 3.0
    axes = np.tile([0.0, 0.0, 1.0], (59, 1))
    stock.threads = 1
    for part in (slice(0, 30), slice(30, 59)):  # two calls: the summaries carry over
        stock.sweep(tips[:-1][part], np.diff(tips, axis=0)[part], axes[part],
                    np.arange(59, dtype=np.int32)[part], shape)
    for grid in stock.grids:
        kept = grid.sweep_index()  # refreshes the flagged tiles
        fresh = material_range(grid.lo, grid.hi, grid.start, grid.count)
        for got, want in zip((kept.mat_lo, kept.mat_hi, kept.gap_lo, kept.gap_hi), fresh,
                             strict=True):
            assert np.array_equal(got, want)
        t_lo, t_hi = tile_bounds(grid.lo, grid.hi, grid.start, grid.count, grid.shape, TILE)
        assert np.array_equal(kept.tile_lo, t_lo) and np.array_equal(kept.tile_hi, t_hi)
        assert not kept.dirty.any()
        assert not kept.acc.any() and kept.touched[0] == 0
