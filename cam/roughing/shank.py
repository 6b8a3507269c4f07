"""The shank and holder of a 3+2 pose kept out of the stock left so far.

The flutes cut whatever they meet; the shank above them and the holder must meet
nothing. ``FixedAxisFrame.keep_shank_clear`` keeps the shank off the design plus the
stock roughing means to leave on it; this module keeps it off the stock the layers
above really left (thicker than that where a wall leans in the region's frame and
the layers step down it): ``shank_floor`` lifts a pose along the axis until every
shank and holder step clears that stock. (The splitter fixture's chain showed why:
a UMR whose axis lies almost radial ran its shank up to 8.5 mm into stock its own
upper layers had left on a wall.)

Each tool part above the flutes is a **step** ``(h, r)``: from height ``h`` above
the ball centre upwards, radius at most ``r`` (``shank_steps``). A pose at ball
centre ``c`` (frame, axis +Z) is clear when no stock lies in any step's cylinder.

1. **Screen** on the region's own Z-map (``stockmap.ZMap``: the blank and this
   region's earlier cuts; it does not know other regions' cuts, so its stock is a
   superset of the real one): the ground's highest node within ``r + margin`` of the
   pose, minus ``h``, is a height at which the step surely clears (``limit``).
2. **Confirm** poses under their limit on the swept stock of every run cut before
   (``sweptstock.SweptStock``, all regions): points ``CLEARANCE`` outside each step's
   side, every ``SPACING`` mm around and up to the Z-map's highest stock there, and
   on its bottom face where it is wider than the step below. A pose with no such
   point in stock stays; the others are lifted to the lowest clear height found by
   bisection between the pose and its limit (``BISECTIONS`` halvings; the clear end
   is kept).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from cam.roughing.dropcutter import DropSurface
from cam.roughing.stockmap import ZMap
from cam.roughing.sweptstock import SweptStock
from cam.tools import Tool

__all__ = ["BISECTIONS", "CLEARANCE", "MARGIN", "SPACING", "ShankGuard", "shank_floor",
           "shank_steps"]

#: Frame points ``(k, 3)`` -> W (``FixedAxisFrame.to_world``).
ToWorld = Callable[[NDArray[np.float64]], NDArray[np.float64]]

#: Test points lie this far outside the shank's and holder's surfaces, mm: more
#: than half the spacing at which cutting moves are refined (``linking.REFINE_STEP``
#: 0.25 mm), so that a pose between two tested ones, lifted only at the next, keeps
#: its shank off a wall it approaches (with a clearance of 0.1 mm instead, verify
#: found the splitter's shank up to 0.54 mm in stock on such moves).
CLEARANCE = 0.15
#: Spacing of the test points around and up the steps, mm.
SPACING = 0.5
#: The Z-map screen looks this much beyond a step's radius (node spacing, moves), mm.
MARGIN = 0.5
#: Halvings of the lift interval of a pose in stock.
BISECTIONS = 6


def shank_steps(tool: Tool) -> list[tuple[float, float]]:
    """``(h, r)`` of the shank and holder segments: bottom height above the ball
    centre and largest radius, mm (tapers taken at their wide end)."""
    r = tool.radius
    return [(seg.z0 - r, max(seg.r0, seg.r1)) for seg in (*tool.shank_segments(), *tool.holder)]


def _ring(radius: float) -> NDArray[np.float64]:
    """``(k, 2)`` points every ``SPACING`` mm (at least 8) around a circle."""
    k = max(8, int(math.ceil(2.0 * math.pi * radius / SPACING)))
    a = 2.0 * math.pi * np.arange(k) / k
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)


def _points(centres: NDArray[np.float64], steps: list[tuple[float, float]],
            tops: NDArray[np.float64], below: float) -> tuple[NDArray[np.float64],
                                                              NDArray[np.int64]]:
    """Test points (frame) of the steps of poses ``centres`` ``(m, 3)`` and the pose
    each belongs to; ``tops`` ``(m, s)``: highest stock near each step (frame z).

    Per step: rings ``CLEARANCE`` outside its side every ``SPACING`` mm from its bottom
    up to ``tops``, and its bottom face (rings inwards to the step below's radius)."""
    pts: list[NDArray[np.float64]] = []
    owner: list[NDArray[np.int64]] = []
    inner = below
    for s, (h, r) in enumerate(steps):
        ring = r + CLEARANCE
        around = _ring(ring)
        # bottom face where this step is wider than the one below
        face = [_ring(rho) for rho in np.arange(ring, inner - 1e-9, -SPACING)]
        bottom = np.concatenate(face) if face else np.zeros((0, 2))
        inner = ring
        base = centres[:, 2] + h
        span = tops[:, s] - base
        poses = np.flatnonzero(span >= 0.0)
        if not len(poses):
            continue
        # as many rings as np.arange(0, span + SPACING, SPACING) gives each pose
        count = np.ceil((span[poses] + SPACING) / SPACING).astype(np.int64)
        level = np.arange(int(count.max()))
        up = level[None, :] < count[:, None]  # (p, levels)
        pose_of, lev = np.nonzero(up)
        z = base[poses][pose_of] + lev * SPACING  # one height per (pose, ring)
        xy = centres[poses][pose_of][:, None, :2] + around[None]
        side = np.concatenate([xy, np.broadcast_to(z[:, None, None], (len(z), len(around), 1))],
                              axis=2).reshape(-1, 3)
        flat = np.concatenate([centres[poses][:, None, :2] + bottom[None],
                               np.broadcast_to(base[poses][:, None, None],
                                               (len(poses), len(bottom), 1))],
                              axis=2).reshape(-1, 3)
        pts += [side, flat]
        owner += [np.repeat(poses[pose_of], len(around)), np.repeat(poses, len(bottom))]
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(pts), np.concatenate(owner)


def _clear(centres: NDArray[np.float64], steps: list[tuple[float, float]],
           tops: NDArray[np.float64], radius: float, to_world: ToWorld,
           swept: SweptStock, before: int) -> NDArray[np.bool_]:
    """Whether the poses ``(m, 3)`` (frame) have no test point in stock."""
    pts, owner = _points(centres, steps, tops, radius + CLEARANCE)
    hit = np.zeros(len(centres), dtype=bool)
    if len(pts):
        world = to_world(pts)
        bad = swept.stock(world, before)
        hit[np.unique(owner[bad])] = True
    return ~hit


def shank_floor(local: NDArray[np.float64], steps: list[tuple[float, float]], zmap: ZMap,
                radius: float, to_world: ToWorld, swept: SweptStock | None,
                before: int = 0) -> tuple[NDArray[np.float64], int]:
    """Lowest ball-centre heights ``(n,)`` (frame z) at which the poses' shank and
    holder meet no stock, and how many poses had to be lifted.

    Parameters
    ----------
    local : (n, 3) float64
        Ball centres in the region's frame, mm.
    steps : list of (float, float)
        ``shank_steps`` of the tool.
    zmap : ZMap
        The region's stock map as it stands before these poses are cut.
    radius : float
        Ball radius R, mm.
    to_world : callable
        Frame points ``(k, 3)`` -> W.
    swept : SweptStock or None
        The cuts of every run before (all regions); ``None``: the Z-map's limit
        stands (no confirmation).
    before : int
        Runs of ``swept`` labelled below this count as cut.
    """
    z = np.asarray(local[:, 2], dtype=np.float64).copy()
    if not steps or not len(z):
        return z, 0
    tops = zmap.highest_within(local, [r + MARGIN for _, r in steps])
    heights = np.array([h for h, _ in steps])
    limit = (tops - heights[None]).max(axis=1)
    under = np.flatnonzero(z < limit)
    if not len(under):
        return z, 0
    if swept is None:
        z[under] = limit[under]
        return z, len(under)
    sub_tops = tops[under]
    ok = _clear(local[under], steps, sub_tops, radius, to_world, swept, before)
    lift = under[~ok]
    lo, hi = z[lift].copy(), limit[lift].copy()
    tops_l = tops[lift]
    for _ in range(BISECTIONS):
        if not len(lift):
            break
        mid = 0.5 * (lo + hi)
        c = local[lift].copy()
        c[:, 2] = mid
        ok = _clear(c, steps, tops_l, radius, to_world, swept, before)
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    z[lift] = hi
    return z, len(lift)


class ShankGuard:
    """A region's drop surface with the shank and holder kept out of the stock.

    ``drop(points)`` ``(n, 3)`` (frame) is the base surface's height (ball and design)
    or, where higher, the height ``shank_floor`` lifts each point to. Unlike a
    drop-cutter it depends on the point's own height (a point whose shank is clear
    keeps it): the callers compare it with the point's height (refined moves, direct
    links, ramps). ``lifted`` counts the points lifted so far.

    Parameters
    ----------
    base : DropSurface
        The frame's ball and design drop surface.
    steps, zmap, radius, to_world, swept, before
        As in ``shank_floor``; ``zmap`` is read as it stands at each call (the
        region's cuts so far).
    """

    def __init__(self, base: DropSurface, steps: list[tuple[float, float]], zmap: ZMap,
                 radius: float, to_world: ToWorld, swept: SweptStock | None,
                 before: int = 0) -> None:
        self.base = base
        self.steps = steps
        self.zmap = zmap
        self.radius = float(radius)
        self.to_world = to_world
        self.swept = swept
        self.before = before
        self.lifted = 0

    def floor(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Heights ``(n,)`` at which the points' shank and holder clear the stock."""
        z, lifted = shank_floor(np.asarray(points, dtype=np.float64).reshape(-1, 3),
                                self.steps, self.zmap, self.radius, self.to_world,
                                self.swept, self.before)
        self.lifted += lifted
        return z

    def drop(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """``max(base.drop, floor)`` at frame points ``(n, 3)``."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return np.asarray(np.maximum(self.base.drop(pts), self.floor(pts)))
