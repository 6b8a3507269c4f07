"""The paper's baseline: simultaneous five-axis roughing of the same passage.

The paper's five-axis layers (eq. 2, option ``baseline_layering``; the 3+2 plan
takes its layers by milling depth) and the 3+2 plan's passes (eq. 9) over the whole
passage (all stations, no UMR split), cut with the axis at every point along the blended
ruling (the ruling of eq. 3 interpolated between the two blade sides like the
passes), the same material test (the ball meets the blank), the same layer order
and the same link rules as the 3+2 plan (``linking.py``), along the tool axis:

* direct cutting link when short (``direct_link``) and the straight ball-centre
  move keeps ``rho`` from the design;
* otherwise **lift** ``lift`` mm along the axis at feed, **rapid** up the axis until
  the ball clears the blank by ``clearance``, rapid across to the same clearance
  above the next run's start (raised until the straight move clears the blank),
  rapid down the next axis to ``entry_height`` above the stock there, then **ramp**
  in at ``entry_angle`` along the run's first move (like the 3+2 plan) or **plunge**
  along the axis where the ramp is not clear or its top not in air;
* the stock above a run's start: the blank less what the runs before have swept
  (``sweptstock.SweptStock``, ball and tool cylinder); the plunge starts ``entry_height``
  above the lowest point down to which the ball comes in air along the axis;
* a run that needs an entry is cut from the end with the shorter entry, unless a
  direct link reaches one of its ends (``plan.oriented_run``, as the 3+2 plan).

**Valid program.** The targets keep R + eta from hub and walls at the hub only;
carried up the blended ruling they come closer than eta to twisted blade sides, so
every ball centre is **pushed clear** (while its distance to the design triangles is
below ``rho = R + eta``, it moves to ``foot + rho (c - foot) / |c - foot|``, a few
rounds), and where the flutes, shank or holder come closer than eta the axis is
**re-tilted** about the ball centre (``retilt.py``). Postures the re-tilt cannot
clear are not cut (counted as ``dropped``). ``run_rough`` checks all moves of the baseline
with python-fcl and its ball centres' allowance, like the 3+2 plan's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from trimesh.triangles import closest_point

from cam.collision.triangle_bvh import TriangleBVH
from cam.roughing.layers import repeats_layer_above
from cam.roughing.linking import LinkSettings
from cam.roughing.passage import PassageGrid
from cam.roughing.plan import Segment, clear_distance, cutting_runs, direct_kind, oriented_run
from cam.roughing.retilt import refine_five_axis, retilt
from cam.roughing.stock import Blank
from cam.roughing.sweptstock import SweptStock
from cam.tools import Tool
from postproc.toolpath import MoveKind

__all__ = ["five_axis_baseline", "nearest_points", "push_clear"]


def nearest_points(triangles: NDArray[np.float64], points: NDArray[np.float64],
                   neighbours: int = 16, tree: cKDTree | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest design points ``(n, 3)`` and distances ``(n,)`` of ``points`` (mm).

    Exact point-triangle distances to the ``neighbours`` triangles with the nearest
    centroids (on regular design grids whose triangles are small against the
    distances asked for, the nearest triangle is among them).
    """
    if tree is None:
        tree = cKDTree(triangles.mean(axis=1))
    neighbours = min(neighbours, len(triangles))
    _, index = tree.query(points, k=neighbours)
    index = np.asarray(index).reshape(len(points), neighbours)
    pts = np.repeat(points, neighbours, axis=0)
    foot = closest_point(triangles[index.reshape(-1)], pts).reshape(-1, neighbours, 3)
    d = np.linalg.norm(foot - points[:, None], axis=2)
    best = np.argmin(d, axis=1)
    rows = np.arange(len(points))
    return foot[rows, best], d[rows, best]


def push_clear(centres: NDArray[np.float64], triangles: NDArray[np.float64], rho: float,
               rounds: int = 100, bvh: TriangleBVH | None = None
               ) -> tuple[NDArray[np.float64], int]:
    """Move ball centres ``(n, 3)`` off the design until each is ``rho`` from it.

    Exact nearest points (``retilt.nearest_on``); in concave corners (fillets) one
    push can bring a centre nearer the other wall, so the still-close ones are pushed
    again, up to ``rounds`` times. Returns the moved centres and how many were moved.
    """
    from cam.roughing.retilt import nearest_on

    c = np.array(centres, dtype=np.float64, copy=True)
    bvh = TriangleBVH(triangles) if bvh is None else bvh
    moved = np.zeros(len(c), dtype=bool)
    active = np.arange(len(c))
    for _ in range(rounds):
        foot, d = nearest_on(bvh, c[active], rho + 1.0)
        bad = d < rho - 1e-9
        if not bad.any():
            break
        active, foot, d = active[bad], foot[bad], d[bad]
        away = (c[active] - foot) / np.maximum(d, 1e-12)[:, None]
        c[active] = foot + (rho + 1e-6) * away
        moved[active] = True
    return c, int(moved.sum())


def _blank_clear(a: NDArray[np.float64], b: NDArray[np.float64], blank: Blank,
                 radius: float, step: float = 1.0) -> bool:
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return not bool(blank.touches(a[None] + t * (b - a)[None], radius).any())


def _ball_clear(a: NDArray[np.float64], b: NDArray[np.float64], bvh: TriangleBVH,
                rho: float, step: float = 0.25) -> bool:
    """The straight ball-centre move a -> b keeps ``rho`` from the design (W)."""
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return bool(np.all(bvh.distances(a[None] + t * (b - a)[None], rho) >= rho - 1e-9))


def _split_unclear(runs: list[NDArray[np.float64]], axes: list[NDArray[np.float64]],
                   bvh: TriangleBVH, rho: float, step: float = 0.25
                   ) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
    """Split runs where the straight move between two consecutive centres comes
    closer than ``rho - 0.05`` to the design (centres pushed clear to opposite sides
    of a thin edge): those become links. A single centre cut off on both sides (a
    target pushed round a leading or trailing edge) is dropped: no process engineer
    links out and back in for one point outside the passage."""
    out_r: list[NDArray[np.float64]] = []
    out_a: list[NDArray[np.float64]] = []
    for run, ax in zip(runs, axes, strict=True):
        if len(run) < 2:
            out_r.append(run)
            out_a.append(ax)
            continue
        a, b = run[:-1], run[1:]
        n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(np.int64), 1)
        owner = np.repeat(np.arange(len(n)), n + 1)
        first = np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
        t = ((np.arange(len(owner)) - first) / n[owner])[:, None]
        d = bvh.distances(a[owner] + t * (b - a)[owner], rho)
        bad = np.zeros(len(n), dtype=bool)
        np.logical_or.at(bad, owner, d < rho - 0.05)
        cuts = np.flatnonzero(bad) + 1
        for piece, piece_ax in zip(np.split(run, cuts), np.split(ax, cuts), strict=True):
            if len(piece) > 1 or len(cuts) == 0:
                out_r.append(piece)
                out_a.append(piece_ax)
    return out_r, out_a


def _ramp_top(run: NDArray[np.float64], axis: NDArray[np.float64], t_in: float,
              previous: NDArray[np.float64], swept: SweptStock, index: int,
              bvh: TriangleBVH, rho: float, angle_deg: float, step: float = 0.5
              ) -> NDArray[np.float64] | None:
    """Top of a ramp onto ``run[0]`` (the 3+2 entry rule, along the tool axis).

    The ramp descends ``t_in`` along ``axis`` at ``angle_deg`` from the plane normal
    to it, coming from behind the run's first move. ``None`` (plunge) when the angle
    is 90 deg, the run has no direction, the ramp's top or the rapid from
    ``previous`` to it is not in air (``swept``, before run ``index``), or the ramp
    comes closer than ``rho`` to the design.
    """
    if angle_deg >= 90.0 or len(run) < 2:
        return None
    d = run[1] - run[0]
    d -= (d @ axis) * axis
    norm = float(np.linalg.norm(d))
    if norm < 1e-9:
        return None
    top = run[0] + t_in * axis - d / norm * t_in / np.tan(np.radians(angle_deg))
    n = max(2, int(np.ceil(np.linalg.norm(top - run[0]) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    ramp = top[None] + t * (run[0] - top)[None]
    if not np.all(bvh.distances(ramp, rho) >= rho - 1e-9):
        return None
    m = max(2, int(np.ceil(np.linalg.norm(top - previous) / step)) + 1)
    u = np.linspace(0.0, 1.0, m)[:, None]
    if not swept.air(previous[None] + u * (top - previous)[None], index).all():
        return None
    return top


def five_axis_baseline(grid: PassageGrid, blank: Blank, tool: Tool, eta: float,
                       settings: LinkSettings, direct_link: float,
                       triangles: NDArray[np.float64], rho: float) -> Segment:
    """Simultaneous five-axis roughing of passage 0 (see module docstring).

    Parameters
    ----------
    tool : Tool
        The ball-end mill (its outline for the re-tilt).
    eta : float
        Finishing allowance, mm.
    settings : LinkSettings
        Lift, clearance, entry height and ramp angle.
    triangles : (m, 3, 3) float64
        Design triangles (W, mm) the ball centres are pushed clear of.
    rho : float
        R + eta (+ tessellation), mm.
    """
    radius = tool.diameter / 2.0
    axis_pts = grid.ruling / np.linalg.norm(grid.ruling, axis=-1, keepdims=True)
    bvh = TriangleBVH(triangles)
    flat, pushed = push_clear(grid.centres.reshape(-1, 3), triangles, rho, bvh=bvh)
    centres = flat.reshape(grid.centres.shape)
    axes = np.ascontiguousarray(np.broadcast_to(axis_pts[None], centres.shape))
    keep = blank.touches(centres, radius) & ~repeats_layer_above(grid.centres)
    flat_axes, tilted, unresolved = retilt(centres[keep], axes[keep], tool, triangles,
                                           eta + (rho - radius - eta), bvh=bvh)
    axes = axes.copy()
    axes[keep] = flat_axes
    dropped = 0
    if unresolved.any():  # not cut: no axis within the tilt bound clears them
        idx = np.argwhere(keep)[unresolved]
        keep[tuple(idx.T)] = False
        dropped = int(len(idx))
    all_runs, all_axes = cutting_runs(keep, centres, axes)
    runs, run_axes = _split_unclear(all_runs, all_axes, bvh, rho)
    points: list[NDArray[np.float64]] = []
    vectors: list[NDArray[np.float64]] = []
    kinds: list[NDArray[np.int8]] = []
    direct = 0
    full = 0
    clearance, height = settings.clearance, settings.entry_height
    ramps = 0

    def add(c: NDArray[np.float64], a: NDArray[np.float64], k: int) -> None:
        points.append(c[None])
        vectors.append(a[None])
        kinds.append(np.array([k], np.int8))

    swept = SweptStock(blank, radius, tool.stickout - radius, runs, run_axes)
    known: dict[tuple[int, bytes], float] = {}

    def entry_depth(index: int, run: NDArray[np.float64], ax: NDArray[np.float64]) -> float:
        """Feed entry length down the axis onto the run's first point, mm (asked for
        both ends by ``oriented_run``, then for the chosen one: kept)."""
        key = (index, run[0].tobytes() + ax[0].tobytes())
        if key not in known:
            t_clear = clear_distance(run[0], ax[0], blank, radius, height)
            known[key] = min(t_clear, swept.approach(run[0], ax[0], t_clear, index) + height)
        return known[key]

    def reachable(run: NDArray[np.float64]) -> bool:
        end = points[-1][-1]
        return bool(np.linalg.norm(run[0] - end) <= direct_link
                    and _ball_clear(end, run[0], bvh, rho))

    for index, (run, ax) in enumerate(zip(runs, run_axes, strict=True)):
        poses = oriented_run(np.hstack([run, ax]), index, bool(points),
                             lambda p: reachable(p[:, :3]),
                             lambda i, p: entry_depth(i, p[:, :3], p[:, 3:]))
        run, ax = poses[:, :3], poses[:, 3:]
        t_in = entry_depth(index, run, ax)
        if points:
            end, end_axis = points[-1][-1], vectors[-1][-1]
            if reachable(run):
                points.append(run)
                vectors.append(ax)
                kinds.append(np.concatenate(
                    [[direct_kind(end, run[0], ax[0])],
                     np.full(len(run) - 1, MoveKind.FEED)]).astype(np.int8))
                direct += 1
                continue
            add(end + settings.lift * end_axis, end_axis, MoveKind.RETRACT)
            up = clear_distance(end, end_axis, blank, radius, clearance)
            over = clear_distance(run[0], ax[0], blank, radius, clearance)
            for _ in range(50):  # raise both until the straight rapid clears the blank
                u, v = end + up * end_axis, run[0] + over * ax[0]
                if _blank_clear(u, v, blank, radius + clearance):
                    break
                up, over = up + 2.0, over + 2.0
            add(u, end_axis, MoveKind.RAPID)
            add(v, ax[0], MoveKind.RAPID)
            full += 1
        else:  # the first run: from its clear point above the blank
            add(run[0] + clear_distance(run[0], ax[0], blank, radius, clearance) * ax[0],
                ax[0], MoveKind.RAPID)
        top = _ramp_top(run, ax[0], t_in, points[-1][-1], swept, index, bvh, rho,
                        settings.entry_angle_deg)
        ramps += top is not None
        points += [(run[0] + t_in * ax[0] if top is None else top)[None], run]
        vectors += [ax[0][None], ax]
        kinds += [np.array([MoveKind.RAPID], np.int8),
                  np.concatenate([[MoveKind.PLUNGE], np.full(len(run) - 1, MoveKind.FEED)]
                                 ).astype(np.int8)]
    end, end_axis = points[-1][-1], vectors[-1][-1]
    add(end + settings.lift * end_axis, end_axis, MoveKind.RETRACT)
    add(end + clear_distance(end, end_axis, blank, radius, clearance) * end_axis, end_axis,
        MoveKind.RAPID)
    c, a, kind, added = refine_five_axis(np.concatenate(points), np.concatenate(vectors),
                                         np.concatenate(kinds), tool, triangles, eta, rho,
                                         bvh=bvh)
    return Segment(c - radius * a, a, kind, False, -1, 0, cut_points=int(keep.sum()),
                   notes={"runs": float(len(runs)), "direct_links": float(direct),
                          "full_links": float(full), "pushed": float(pushed),
                          "retilted": float(tilted.sum()), "dropped": float(dropped),
                          "refined": float(added), "ramps": float(ramps)})
