"""Roughing plan: CL points per UMR, layer and pass, links, and the 5-axis baseline.

``plan_roughing`` (command.py) does the whole method on passage 0 and turns the
result about +Z for the other passages. Here:

* **3+2 region** (``region_segment``): each UMR cuts the stations of its u-range in
  the layers of one visit (the grid's: by milling depth or eq. 2, ``layers.py``;
  ``layer_visits``: every UMR's upper layers
  before any UMR's lower ones) and every pass (eq. 9), zigzag, in the UMR frame
  (axis = +Z). A CL
  point is the target's XY with the height ``max(target, drop)``, the drop-cutter
  height being the lowest ball position (radius R + eta) along the axis touching no
  design triangle. A point is cut only where material is: its ball meets the blank,
  the drop lifts it less than one layer depth above its target (more means the
  target lies in a blade's shadow for this axis: the layer above already cut that
  height), and it does not repeat the clamped height of the layer above (nor the
  target of the layer above: ``"depth"`` layering reaches the hub early on short
  rulings, ``layers.depth_layer_points``). With the
  tool's shank steps, a point is also lifted until its shank and holder meet none of
  the stock left before the visit (``shank.ShankGuard``, which is then the drop
  surface of the visit's refined moves, direct links and entries too).
* **Order and links** (both plans): layers alternate direction, so each layer ends
  above the start of the next; two consecutive runs are joined by one direct
  cutting move when it is at most ``direct_link_mm`` long and safe (drop-cutter
  along it), otherwise by a short feed lift, rapids at the lowest safe height over
  the stock left so far (``stockmap.ZMap``, updated run by run) and the design, a
  rapid approach to just above the stock at the next start and a ramp or plunge
  (``linking.py``); a plunge may start lower where ``sweptstock.SweptStock`` knows
  earlier regions cut the material. A run that needs such an entry is cut from
  whichever end has the shorter feed entry (``oriented_run``: often the end next to a
  region cut before), unless a direct link reaches one of its ends.
* **Feed moves between CL points** are refined: each is sampled every
  ``REFINE_STEP`` mm and the drop-cutter height inserted where the straight move
  would dip below it, so the ball keeps eta from the design along the moves, not
  only at the points. The runs are refined before the swept stock is built from
  them, so it holds the cuts the program makes.
* The simultaneous five-axis baseline (``baseline.py``) uses the same ordering and
  link rules.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from cam.roughing.dropcutter import DropCutter, DropSurface
from cam.roughing.layers import repeats_layer_above
from cam.roughing.linking import LinkSettings, entry_moves, link_runs, refine_moves
from cam.roughing.passage import PassageGrid
from cam.roughing.passes import rotate_z, zigzag_order
from cam.roughing.shank import ShankGuard
from cam.roughing.stock import Blank
from cam.roughing.stockmap import ZMap
from cam.roughing.sweptstock import APPROACH_STEP, SweptStock
from cam.roughing.umr import UMR, FixedAxisFrame
from postproc.toolpath import MoveKind

__all__ = [
    "Segment", "clear_distance", "cutting_runs", "direct_kind", "layer_visits", "oriented_run",
    "region_segment",
    "rotate_segment", "safe_height_of", "stock_map",
]

Progress = Callable[[int, int, str], None]


@dataclass
class Segment:
    """Poses of one region of one passage (W, mm) before feeds are attached.

    ``kind`` is the ``MoveKind`` of the move ending at each pose; ``axis`` is constant
    for a 3+2 segment. ``notes`` counts links (``direct``, ``full``) and refinements.
    ``layers``: the first and last layer a 3+2 segment cuts (its UMR's visit of those
    layers, ``layer_visits``).
    """

    tip: NDArray[np.float64]
    axis: NDArray[np.float64]
    kind: NDArray[np.int8]
    fixed: bool
    umr: int
    passage: int
    ramps: int = 0
    plunges: int = 0
    cut_points: int = 0
    notes: dict[str, float] = field(default_factory=dict)
    layers: tuple[int, int] = (0, -1)


def layer_order(n_layers: int, n_passes: int, n_stations: int) -> list[NDArray[np.int64]]:
    """Flat zigzag indices of each layer, odd layers reversed (a layer ends above the
    start of the next one)."""
    base = zigzag_order(n_passes, n_stations)
    return [base if k % 2 == 0 else base[::-1].copy() for k in range(n_layers)]


def cutting_runs(keep: NDArray[np.bool_], *fields_: NDArray[np.float64]
                 ) -> list[list[NDArray[np.float64]]]:
    """Runs of consecutive kept points, per layer in ``layer_order``.

    ``keep`` is ``(L, P, S)``; every field ``(L, P, S, 3)``. Returns one list per field
    (the runs of all layers in cutting order).
    """
    layers, n_p, n_s = keep.shape
    out: list[list[NDArray[np.float64]]] = [[] for _ in fields_]
    for k, order in enumerate(layer_order(layers, n_p, n_s)):
        flat_keep = keep[k].reshape(-1)[order]
        edges = np.flatnonzero(np.diff(np.concatenate([[0], flat_keep.astype(np.int8), [0]])))
        for f, values in enumerate(fields_):
            flat = values[k].reshape(-1, 3)[order]
            out[f] += [flat[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return out


def layer_visits(layer_steps: list[int], per_visit: int
                 ) -> list[tuple[tuple[int, int], int]]:
    """Cut order of the regions' layers: ``((first, last), region)`` per visit.

    Region ``r`` has layers ``0 .. layer_steps[r]`` (0 at the shroud). Every region
    cuts ``per_visit`` layers in turn, from the shroud down; 0: all layers of a
    region in one visit (UMR-major). Consecutive visits of one region (no other
    region between them) are one visit. E.g. ``layer_visits([2, 1], 2)`` gives
    ``[((0, 1), 0), ((0, 1), 1), ((2, 2), 0)]``.
    """
    step = per_visit if per_visit > 0 else max(layer_steps, default=0) + 1
    deepest = max(layer_steps, default=-1)
    visits: list[tuple[tuple[int, int], int]] = []
    for first in range(0, deepest + 1, step):
        for r, n1 in enumerate(layer_steps):
            if first > n1:
                continue
            last = min(first + step - 1, n1)
            if visits and visits[-1][1] == r:
                visits[-1] = ((visits[-1][0][0], last), r)
            else:
                visits.append(((first, last), r))
    return visits


def direct_kind(a: NDArray[np.float64], b: NDArray[np.float64],
                 axis: NDArray[np.float64]) -> int:
    """A direct connection that goes down the axis is a plunge, otherwise a feed."""
    return int(MoveKind.PLUNGE if float(np.dot(b - a, axis)) < -1e-6 else MoveKind.FEED)


def region_segment(umr: UMR, grid: PassageGrid, blank: Blank, blank_triangles: NDArray[np.float64],
                   radius: float, settings: LinkSettings, direct_link: float, reach: float = 0.0,
                   prior: list[Segment] | None = None, layers: tuple[int, int] | None = None,
                   stock: ZMap | None = None,
                   shank: list[tuple[float, float]] | None = None) -> Segment:
    """The 3+2 poses of one UMR in passage 0 (see module docstring).

    ``blank_triangles`` ``(m, 3, 3)``: the blank's closed boundary in W
    (``Blank.closed_mesh``), the stock map's top. ``prior``: the segments of passage 0
    cut before this one; with ``reach`` (the tool's cylinder above the ball centre,
    mm) > 0 their cuts and this region's runs form a ``SweptStock`` that can start a
    plunge lower than the region's own stock map knows. ``layers``: the first and
    last layer (inclusive) cut by this segment (default all); ``stock``: the region's
    stock map carried over from its segments of the layers above (default a fresh
    one; it is updated in place). ``shank``: the tool's ``shank.shank_steps``; given,
    every point is lifted where its shank or holder would meet the stock left before
    this visit (``shank.shank_floor``).
    """
    frame = umr.frame
    first_station, last_station = umr.stations
    targets = frame.to_frame(grid.centres[:, :, first_station:last_station + 1])
    floor = frame.cut_floor(targets.reshape(-1, 3)).reshape(targets.shape[:-1])
    z = np.maximum(targets[..., 2], floor)
    depth = grid.depth
    band = np.zeros(len(z), dtype=bool)
    band[slice(None) if layers is None else slice(layers[0], layers[1] + 1)] = True
    zmap = stock_map(frame, grid, blank_triangles, radius) if stock is None else stock
    old = [c for p in prior or [] for c in _cut_chains(p.tip + radius * p.axis, p.axis,
                                                        p.kind)]
    cutter: DropSurface = frame.tool
    guard = None
    if shank:
        # the stock as this visit finds it: the region's map and every earlier cut
        before = (SweptStock(blank, radius, reach, [c for c, _ in old], [a for _, a in old])
                  if reach > 0.0 and old else None)
        guard = ShankGuard(frame.tool, shank, zmap, radius, frame.to_world, before, len(old))
        cutter = guard
        cand = band[:, None, None] & (z - targets[..., 2] <= depth)
        pts = targets[cand]
        pts[:, 2] = z[cand]
        z[cand] = guard.floor(pts)
    lift = z - targets[..., 2]
    clamped = lift > 1e-6
    local = targets.copy()
    local[..., 2] = z
    world = frame.to_world(local)
    material = blank.touches(world, radius)
    repeated = np.zeros_like(clamped)
    repeated[1:] = clamped[1:] & clamped[:-1] & (z[1:] > z[:-1] - 0.25 * depth)
    repeated |= repeats_layer_above(grid.centres[:, :, first_station:last_station + 1])
    shadow = lift > depth
    material &= band[:, None, None]
    keep = material & ~repeated & ~shadow
    (runs,) = cutting_runs(keep, local)
    # as cut: the moves between CL points lifted onto the drop surface (what ``emit``
    # does), so the swept stock below knows the cuts the program really makes
    refined = [refine_moves(r, np.concatenate([[MoveKind.RAPID], np.full(len(r) - 1, MoveKind.FEED)]
                                              ).astype(np.int8), cutter) for r in runs]
    runs = [c for c, _, _ in refined]
    swept = None
    if reach > 0.0:
        swept = SweptStock(blank, radius, reach, [c for c, _ in old] + [frame.to_world(r)
                                                                          for r in runs],
                           [a for _, a in old] + [np.broadcast_to(frame.axis, r.shape)
                                                  for r in runs],
                           [-1] * len(old) + list(range(len(runs))))
    up = np.array([0.0, 0.0, 1.0])

    known: dict[tuple[int, bytes], float | None] = {}

    def lowest(index: int, start: NDArray[np.float64]) -> float | None:
        """Frame height down to which the swept stock says a plunge is in air (above
        the stock map's entry top when the swept stock finds that top in stock).

        Asked for both ends of a run (``oriented_run``) and again for the chosen one
        while the stock map stands still (run ``index`` not yet emitted): kept.
        """
        key = (index, start.tobytes())
        if key not in known:
            known[key] = _lowest(index, start)
        return known[key]

    def _lowest(index: int, start: NDArray[np.float64]) -> float | None:
        if swept is None:
            return None
        top = float(max(zmap.air_height(start[None])[0], start[2])) + settings.entry_height
        if not np.isfinite(top):
            return None
        origin = frame.to_world(start)
        t = swept.approach(origin, frame.axis, top - float(start[2]), index)
        if not swept.air((origin + t * frame.axis)[None], index)[0]:
            # the stock map's entry top is not in air (a wedge of stock between its
            # nodes, e.g. a face almost parallel to the axis): come down from higher
            t = swept.rise(origin, frame.axis, t + APPROACH_STEP,
                           settings.safe_height - float(start[2]), index)
        return float(start[2]) + t
    centres: list[NDArray[np.float64]] = []
    kinds: list[NDArray[np.int8]] = []
    counts = {"direct": 0, "full": 0, "ramps": 0, "plunges": 0,
              "refined": sum(added for _, _, added in refined)}
    last: NDArray[np.float64] = np.zeros(3)

    def emit(piece: NDArray[np.float64], kind: NDArray[np.int8]) -> None:
        """Refine the piece's cutting moves, sweep them into the stock, keep them."""
        nonlocal last
        lead = (last if centres else piece[0])[None]
        c, k, added = refine_moves(np.concatenate([lead, piece]),
                                   np.concatenate([[MoveKind.RAPID], kind]).astype(np.int8),
                                   cutter)
        counts["refined"] += added
        zmap.sweep_moves(c, k)
        centres.append(c[1:])
        kinds.append(k[1:])
        last = c[-1]

    def entry_cost(index: int, run: NDArray[np.float64]) -> float:
        """Length of the feed entry (ramp or plunge) onto the run's first point, mm."""
        direction = run[1] - run[0] if len(run) > 1 else None
        entry, _, _ = entry_moves(run[0], direction, cutter, zmap, settings,
                                  lowest(index, run[0]))
        return float(np.linalg.norm(entry[1] - entry[0]))

    def reachable(run: NDArray[np.float64]) -> bool:
        return bool(np.linalg.norm(run[0] - last) <= direct_link
                    and _line_clear(last, run[0], cutter))

    for index, run in enumerate(runs):
        run = oriented_run(run, index, bool(centres), reachable, entry_cost)
        direction = run[1] - run[0] if len(run) > 1 else None
        if index == 0:
            entry, entry_kind, ramped = entry_moves(run[0], direction, cutter, zmap,
                                                    settings, lowest(index, run[0]))
            top = entry[0].copy()
            top[2] = settings.safe_height
            piece, kind = np.concatenate([top[None], entry]), np.concatenate(
                [[MoveKind.RAPID], entry_kind]).astype(np.int8)
            counts["ramps" if ramped else "plunges"] += 1
        elif reachable(run):
            piece = run[0][None]
            kind = np.array([direct_kind(last, run[0], up)], np.int8)
            counts["direct"] += 1
        else:
            piece, kind, ramped = link_runs(last, run[0], direction, cutter, zmap,
                                            settings, lowest(index, run[0]))
            counts["full"] += 1
            counts["ramps" if ramped else "plunges"] += 1
        emit(np.concatenate([piece, run[1:]]),
             np.concatenate([kind, np.full(len(run) - 1, MoveKind.FEED, np.int8)]))
    if centres:
        out = last + np.array([0.0, 0.0, settings.lift])
        top = last.copy()
        top[2] = max(settings.safe_height, float(out[2]))
        centres += [out[None], top[None]]
        kinds.append(np.array([MoveKind.RETRACT, MoveKind.RAPID], np.int8))
        local_all = np.concatenate(centres)
        kind = np.concatenate(kinds)
    else:
        local_all = np.zeros((0, 3))
        kind = np.zeros(0, np.int8)
    world_centres = frame.to_world(local_all)
    tip = world_centres - radius * frame.axis
    axis = np.broadcast_to(frame.axis, tip.shape).copy()
    notes = {"direct_links": float(counts["direct"]), "full_links": float(counts["full"]),
             "refined": float(counts["refined"]), "runs": float(len(runs)),
             "shadow_points": float((material & shadow).sum()),
             "shank_lifted": float(0 if guard is None else guard.lifted)}
    return Segment(tip, axis, kind, True, umr.index, 0, counts["ramps"], counts["plunges"],
                   int(keep.sum()), notes,
                   (0, len(z) - 1) if layers is None else (layers[0], layers[1]))


def oriented_run(run: NDArray[np.float64], index: int, linked: bool,
              reachable: Callable[[NDArray[np.float64]], bool],
              entry_cost: Callable[[int, NDArray[np.float64]], float]) -> NDArray[np.float64]:
    """The run as cut: as planned, or reversed when that saves feed entry.

    ``run`` (n, c): poses, the first 3 columns the ball centre (more columns, e.g. the
    axis, are reversed with them); ``reachable(run)``: a direct link from the last
    cut reaches ``run[0]``; ``entry_cost(index, run)``: length of the feed entry onto
    ``run[0]``, mm. A zigzag run can be cut from either end. Kept as planned when a direct link from
    the previous run reaches it (so alternating layers still step straight down);
    reversed when only the reversed run can be reached directly; otherwise the end
    whose feed entry (ramp or plunge from just above the stock left there) is shorter
    is the start, e.g. the end next to a region cut before rather than the end under
    uncut blank.
    """
    if len(run) < 2:
        return run
    if linked and reachable(run):
        return run
    back = run[::-1].copy()
    if linked and reachable(back):
        return back
    return back if entry_cost(index, back) < entry_cost(index, run) - 1e-6 else run


def _cut_chains(centres: NDArray[np.float64], axes: NDArray[np.float64],
                kind: NDArray[np.int8]) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Chains of consecutive non-rapid moves (with their start poses) of a segment."""
    rapid = np.concatenate([[True], kind[1:] == MoveKind.RAPID])
    edges = np.flatnonzero(np.diff(np.concatenate([[0], (~rapid).astype(np.int8), [0]])))
    return [(centres[a - 1:b], axes[a - 1:b]) for a, b in zip(edges[::2], edges[1::2],
                                                               strict=True)]


def stock_map(frame: FixedAxisFrame, grid: PassageGrid, blank_triangles: NDArray[np.float64],
              radius: float, margin: float = 40.0, cell: float = 0.5) -> ZMap:
    """A fresh stock map (the blank, nothing cut) of passage 0 in a UMR's frame.

    It covers the frame XY of every target of the passage plus ``margin`` mm (links and
    ramps); ``blank_triangles`` in W.
    """
    xy = frame.to_frame(grid.centres.reshape(-1, 3))[:, :2]
    lo, hi = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    return ZMap(lo, hi, blank_triangles @ frame.matrix.T, radius, cell)


def _line_clear(a: NDArray[np.float64], b: NDArray[np.float64], cutter: DropSurface,
                step: float = 0.25) -> bool:
    """The straight ball-centre move a -> b (frame) stays on or above the drop surface."""
    n = max(2, int(math.ceil(float(np.linalg.norm(b - a)) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    pts = a[None] + t * (b - a)[None]
    return bool(np.all(cutter.drop(pts) <= pts[:, 2] + 1e-9))


def rotate_segment(segment: Segment, passage: int, pitch: float) -> Segment:
    """The segment turned by ``passage * pitch`` about +Z (the next passage)."""
    angle = passage * pitch
    return Segment(rotate_z(segment.tip, angle), rotate_z(segment.axis, angle),
                   segment.kind.copy(), segment.fixed, segment.umr, passage, segment.ramps,
                   segment.plunges, segment.cut_points, dict(segment.notes), segment.layers)


def clear_distance(point: NDArray[np.float64], axis: NDArray[np.float64], blank: Blank,
                   radius: float, clearance: float, step: float = 0.5) -> float:
    """Distance along ``axis`` (W) that takes the ball at ``point`` (W) ``clearance``
    off the blank, mm."""
    t = np.arange(0.0, 400.0, step)
    inside = blank.touches(point[None] + t[:, None] * axis[None], radius + clearance)
    free = np.flatnonzero(~inside)
    return float(t[free[0]]) if free.size else float(t[-1])


def safe_height_of(umr: UMR, envelope: DropCutter, distance: float) -> float:
    """Frame height above every design and blank point, plus ``distance``, mm."""
    return max(umr.frame.top, float(envelope.triangles[:, :, 2].max())) + distance
