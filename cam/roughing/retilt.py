"""Re-tilt five-axis postures whose flutes, shank or holder come closer than eta.

The baseline's axis is the blended ruling; carried up the twisted passage, the tool's
straight part (flutes, shank) and holder can come closer than the allowance eta to a
blade although the ball centre keeps ``R + eta``. A five-axis program tilts the axis
there. For each posture (ball centre ``c``, unit axis ``a``) the tool outline is
sampled along the axis (heights ``h`` above the tip, radius ``r(h)``: cutter, shank,
holder frusta of ``cam.tools.Tool``); the sample ``s = c + (h - R) a`` must keep
``r(h) + eta + margin`` from the design. While one does not, the axis turns about the
ball centre, away from the nearest design point of the worst sample, by the angle
that moves that sample clear: ``(need - d) / (h - R)``; a few rounds, and the tilt
from the original axis is bounded by ``max_tilt``. The ball centre never moves.
Distances are exact point-triangle distances (``cam.collision.triangle_bvh``, its
public ``distances``); the collision service (python-fcl) is the final check.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam.collision.triangle_bvh import TriangleBVH
from cam.tools import Tool

__all__ = ["clearance_of", "nearest_on", "outline_samples", "refine_five_axis", "retilt"]


#: Step of the finite differences that give the direction away from the design, mm.
GRADIENT_STEP = 1e-3


def nearest_on(bvh: TriangleBVH, points: NDArray[np.float64], reach: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest design points ``(k, 3)`` and exact distances ``(k,)`` within ``reach``.

    Distances are exact (``TriangleBVH.distances``); the nearest point is
    ``p - d grad d`` with the distance gradient by forward differences
    (``GRADIENT_STEP``; the distance field is smooth off the medial axis). Points
    farther than ``reach`` get distance ``inf`` and themselves as foot.
    """
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    dist = bvh.distances(pts, float(reach))
    foot = pts.copy()
    found = np.isfinite(dist)
    if found.any():
        p = pts[found]
        d = dist[found]
        grad = np.stack([bvh.distances(p + GRADIENT_STEP * e, float(reach) + 1.0)
                         for e in np.eye(3)], axis=1) - d[:, None]
        grad /= np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-300)
        foot[found] = p - d[:, None] * grad
    return foot, dist


def _nearest_grouped(bvh: TriangleBVH, pts: NDArray[np.float64], reach: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest points / distances of outline samples ``(n, k, 3)`` with a reach per
    sample height ``(k,)`` (queries grouped by reach: a short reach is much faster)."""
    foot = np.empty_like(pts)
    dist = np.empty(pts.shape[:2])
    for value in np.unique(np.round(reach, 1)):
        cols = np.flatnonzero(np.round(reach, 1) == value)
        f, d = nearest_on(bvh, pts[:, cols].reshape(-1, 3), float(reach[cols].max()))
        foot[:, cols] = f.reshape(len(pts), len(cols), 3)
        dist[:, cols] = d.reshape(len(pts), len(cols))
    return foot, dist


def outline_samples(tool: Tool, step: float = 1.0) -> tuple[NDArray[np.float64],
                                                              NDArray[np.float64]]:
    """Heights above the tip ``(k,)`` and outline radii ``(k,)`` of a ball tool's
    straight part, shank and holder, every ``step`` mm from the ball's centre up, mm."""
    radius = tool.diameter / 2.0
    segs = [(radius, tool.flute_length, radius, radius)]
    top = tool.flute_length
    if tool.stickout > top:
        segs.append((top, tool.stickout, tool.shank_diameter / 2.0,
                     tool.shank_diameter / 2.0))
    for s in tool.holder:
        segs.append((s.z0, s.z1, s.r0, s.r1))
    h_out, r_out = [], []
    for z0, z1, r0, r1 in segs:
        n = max(int(math.ceil((z1 - z0) / step)), 1)
        h = np.linspace(z0, z1, n + 1)
        h_out.append(h)
        r_out.append(r0 + (r1 - r0) * (h - z0) / max(z1 - z0, 1e-12))
    h_all = np.concatenate(h_out)
    r_all = np.concatenate(r_out)
    keep = h_all > radius + 1e-9
    return h_all[keep], r_all[keep]


def retilt(centres: NDArray[np.float64], axes: NDArray[np.float64], tool: Tool,
           triangles: NDArray[np.float64], eta: float, *, margin: float = 0.15,
           rounds: int = 12, max_tilt_deg: float = 40.0, bvh: TriangleBVH | None = None
           ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
    """Axes ``(n, 3)`` turned about the ball ``centres`` ``(n, 3)`` until the tool
    outline keeps ``eta + margin`` from ``triangles`` ``(m, 3, 3)`` (W, mm).

    Returns
    -------
    axes : (n, 3) float64
        Unit axes (unchanged where already clear).
    tilted : (n,) bool
        Postures whose axis was turned.
    unresolved : (n,) bool
        Postures still closer than ``eta + margin`` after ``rounds`` (or at the tilt
        bound): the caller lifts or reports them.
    """
    radius = tool.diameter / 2.0
    h, r = outline_samples(tool)
    rel = h - radius
    need = r + eta + margin
    a = np.array(axes, dtype=np.float64, copy=True)
    a0 = a.copy()
    bvh = TriangleBVH(triangles) if bvh is None else bvh
    tilted = np.zeros(len(a), dtype=bool)
    todo = np.arange(len(a))
    cos_max = math.cos(math.radians(max_tilt_deg))
    unresolved = np.zeros(len(a), dtype=bool)
    for _ in range(rounds):
        if not len(todo):
            break
        pts = centres[todo][:, None] + rel[None, :, None] * a[todo][:, None]
        foot, d = _nearest_grouped(bvh, pts, need + 1.0)
        viol = need[None] - d
        worst = np.argmax(viol / rel[None], axis=1)
        rows = np.arange(len(todo))
        bad = viol[rows, worst] > 0.0
        todo, worst, rows = todo[bad], worst[bad], rows[bad]
        if not len(todo):
            break
        away = pts[rows, worst] - foot[rows, worst]
        ax = a[todo]
        away -= np.einsum("ij,ij->i", away, ax)[:, None] * ax
        norm = np.linalg.norm(away, axis=1)
        ok = norm > 1e-9
        angle = (viol[rows, worst] + 0.02) / rel[worst]
        turned = ax + np.tan(angle)[:, None] * away / np.maximum(norm, 1e-12)[:, None]
        turned /= np.linalg.norm(turned, axis=1, keepdims=True)
        within = np.einsum("ij,ij->i", turned, a0[todo]) >= cos_max
        move = ok & within
        a[todo[move]] = turned[move]
        tilted[todo[move]] = True
        unresolved[todo[~move]] = True
        todo = todo[move]
    if len(todo):  # still violating after the last round
        pts = centres[todo][:, None] + rel[None, :, None] * a[todo][:, None]
        _, d = _nearest_grouped(bvh, pts, need + 1.0)
        unresolved[todo] |= (need[None] - d > 0.0).any(axis=1)
    return a, tilted, unresolved


def clearance_of(bvh: TriangleBVH, centres: NDArray[np.float64], axes: NDArray[np.float64],
                 tool: Tool, reach: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ball-centre distance minus R, and the smallest outline clearance (distance minus
    outline radius) of postures ``(n, 3)``/``(n, 3)`` to the design, mm (capped at
    ``reach``)."""
    radius = tool.diameter / 2.0
    h, r = outline_samples(tool)
    _, d_ball = nearest_on(bvh, centres, radius + reach)
    pts = centres[:, None] + (h - radius)[None, :, None] * axes[:, None]
    _, d = _nearest_grouped(bvh, pts, r + reach)
    outline = (d - r[None]).min(axis=1)
    return np.minimum(d_ball - radius, reach), np.minimum(outline, reach)


def refine_five_axis(centres: NDArray[np.float64], axes: NDArray[np.float64],
                     kind: NDArray[np.int8], tool: Tool, triangles: NDArray[np.float64],
                     eta: float, rho: float, *, step_mm: float = 0.5, step_deg: float = 1.0,
                     rounds: int = 12, bvh: TriangleBVH | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                               NDArray[np.int8], int]:
    """Insert postures where a five-axis move between two clear postures is not clear.

    Each move ``i-1 -> i`` (``kind[i]``: its ``MoveKind``) is sampled (centre linear,
    axis normalised linear) every ``step_mm`` / ``step_deg``; where a sample's ball
    centre is nearer than ``rho - 0.05`` or its outline nearer than ``eta + 0.05`` to
    the design (the collision check grows the cutter by ``eta - 0.05``), the worst
    sample is inserted as a posture of its own, pushed clear and re-tilted;
    ``rounds`` times at most.

    Returns
    -------
    centres, axes : (m, 3) float64
    kind : (m,) int8
        Inserted postures belong to the move they split (same kind).
    added : int
    """
    from cam.roughing.baseline import push_clear

    radius = tool.diameter / 2.0
    bvh = TriangleBVH(triangles) if bvh is None else bvh
    added = 0
    c, a, cut = centres.copy(), axes.copy(), kind.copy()
    ball_end, outline_end = clearance_of(bvh, c, a, tool, 2.0)
    for _ in range(rounds):
        # a move can come closer than its ends only by its chord's sag (short moves
        # near an edge) or its rotation: moves between postures that keep more
        # than needed and turn less than 2 deg are skipped
        moves = np.arange(1, len(c))
        p, q, u, v = c[moves - 1], c[moves], a[moves - 1], a[moves]
        ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", u, v), -1.0, 1.0)))
        slack = np.minimum(np.minimum(ball_end[:-1], ball_end[1:]) - (rho - radius),
                           np.minimum(outline_end[:-1], outline_end[1:]) - eta)
        near = (slack < 0.5) | (ang > 2.0)
        moves, p, q, u, v, ang = (x[near] for x in (moves, p, q, u, v, ang))
        if not len(moves):
            break
        n = np.maximum(np.ceil(np.maximum(np.linalg.norm(q - p, axis=1) / step_mm,
                                          ang / step_deg)).astype(np.int64), 1)
        owner = np.repeat(np.arange(len(moves)), n - 1)
        if not len(owner):
            break
        first = np.repeat(np.cumsum(n - 1) - (n - 1), n - 1)
        t = ((np.arange(len(owner)) - first + 1) / n[owner])[:, None]
        sc = p[owner] + t * (q - p)[owner]
        sa = u[owner] + t * (v - u)[owner]
        sa /= np.linalg.norm(sa, axis=1, keepdims=True)
        ball, outline = clearance_of(bvh, sc, sa, tool, 2.0)
        deficit = np.maximum(rho - radius - 0.05 - ball, eta + 0.05 - outline)
        bad = deficit > 1e-6
        if not bad.any():
            break
        idx = np.flatnonzero(bad)
        idx = idx[np.lexsort((-deficit[idx], owner[idx]))]
        idx = idx[np.concatenate([[True], owner[idx][1:] != owner[idx][:-1]])]
        new_c, _ = push_clear(sc[idx], triangles, rho, bvh=bvh)
        new_a, _, _ = retilt(new_c, sa[idx], tool, triangles, eta + (rho - radius - eta),
                             bvh=bvh)
        at = moves[owner[idx]]
        c = np.insert(c, at, new_c, axis=0)
        a = np.insert(a, at, new_a, axis=0)
        cut = np.insert(cut, at, cut[at])
        b_new, o_new = clearance_of(bvh, new_c, new_a, tool, 2.0)
        ball_end = np.insert(ball_end, at, b_new)
        outline_end = np.insert(outline_end, at, o_new)
        added += len(idx)
    return c, a, cut, added
