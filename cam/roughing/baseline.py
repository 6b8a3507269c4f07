"""The paper's baseline: simultaneous five-axis roughing of the same passage.

The same layers (eq. 2) and passes (eq. 9) as the 3+2 plan over the whole passage
(all stations, no UMR split), cut with the axis at every point along the blended
ruling (the ruling of eq. 3 interpolated between the two blade sides like the
passes), the same material test (the ball meets the blank), the same layer order
and link rules (direct cutting link when short; else retract along the tool axis at
feed until the ball clears the blank, rapid, plunge along the axis).

The targets keep R + eta from hub and walls at the hub only; carried up the blended
ruling they come closer than eta to twisted blade sides. Every baseline ball centre
is therefore **pushed clear**: while its distance to the design triangles is below
``rho = R + eta``, it moves to ``foot + rho (c - foot) / |c - foot|`` (foot: the
nearest design point), a few rounds. Shank and holder are not re-postured (the axis
stays the blended ruling); ``run_rough`` reports the baseline's remaining
collisions next to its time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from trimesh.triangles import closest_point

from cam.roughing.passage import PassageGrid
from cam.roughing.plan import Segment, clear_distance, cutting_runs, direct_kind
from cam.roughing.stock import Blank
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
               rounds: int = 6) -> tuple[NDArray[np.float64], int]:
    """Move ball centres ``(n, 3)`` off the design until each is ``rho`` from it.

    Returns the moved centres and how many were moved.
    """
    c = np.array(centres, dtype=np.float64, copy=True)
    tree = cKDTree(triangles.mean(axis=1))
    moved = np.zeros(len(c), dtype=bool)
    for _ in range(rounds):
        foot, d = nearest_points(triangles, c, tree=tree)
        bad = d < rho - 1e-9
        if not bad.any():
            break
        away = (c[bad] - foot[bad]) / np.maximum(d[bad], 1e-12)[:, None]
        c[bad] = foot[bad] + (rho + 1e-6) * away
        moved |= bad
    return c, int(moved.sum())


def five_axis_baseline(grid: PassageGrid, blank: Blank, radius: float, clearance: float,
                       direct_link: float, triangles: NDArray[np.float64],
                       rho: float) -> Segment:
    """Simultaneous five-axis roughing of passage 0 (see module docstring).

    Parameters
    ----------
    triangles : (m, 3, 3) float64
        Design triangles (W, mm) the ball centres are pushed clear of.
    rho : float
        R + eta, mm.
    """
    axis_pts = grid.ruling / np.linalg.norm(grid.ruling, axis=-1, keepdims=True)
    flat, pushed = push_clear(grid.centres.reshape(-1, 3), triangles, rho)
    centres = flat.reshape(grid.centres.shape)
    axes = np.ascontiguousarray(np.broadcast_to(axis_pts[None], centres.shape))
    keep = blank.touches(centres, radius)
    runs, run_axes = cutting_runs(keep, centres, axes)
    points: list[NDArray[np.float64]] = []
    vectors: list[NDArray[np.float64]] = []
    kinds: list[NDArray[np.int8]] = []
    direct = 0
    full = 0

    def retract(end: NDArray[np.float64], end_axis: NDArray[np.float64]) -> None:
        back = clear_distance(end, end_axis, blank, radius, clearance)
        points.append((end + back * end_axis)[None])
        vectors.append(end_axis[None])
        kinds.append(np.array([MoveKind.RETRACT], np.int8))

    for run, ax in zip(runs, run_axes, strict=True):
        if points:
            end, end_axis = points[-1][-1], vectors[-1][-1]
            if np.linalg.norm(run[0] - end) <= direct_link:
                points.append(run)
                vectors.append(ax)
                kinds.append(np.concatenate(
                    [[direct_kind(end, run[0], ax[0])],
                     np.full(len(run) - 1, MoveKind.FEED)]).astype(np.int8))
                direct += 1
                continue
            retract(end, end_axis)
            full += 1
        lift = clear_distance(run[0], ax[0], blank, radius, clearance)
        points += [(run[0] + lift * ax[0])[None], run]
        vectors += [ax[0][None], ax]
        kinds += [np.array([MoveKind.RAPID], np.int8),
                  np.concatenate([[MoveKind.PLUNGE], np.full(len(run) - 1, MoveKind.FEED)]
                                 ).astype(np.int8)]
    retract(points[-1][-1], vectors[-1][-1])
    c = np.concatenate(points)
    a = np.concatenate(vectors)
    return Segment(c - radius * a, a, np.concatenate(kinds), False, -1, 0,
                   cut_points=int(keep.sum()),
                   notes={"runs": float(len(runs)), "direct_links": float(direct),
                          "full_links": float(full), "pushed": float(pushed)})
