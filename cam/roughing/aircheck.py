"""Proof that no rapid move cuts: every rapid of both plans is checked against stock.

Rebuilt from the finished programs of passage 0 (the other passages are rotations of
it about the blank's axis), independent of the link planner's own bookkeeping:

* **3+2 segment** (``fixed_axis_rapids``): replayed in order through a
  ``stockmap.ZMap`` of the UMR's frame (the blank, then every cutting move of the
  UMR's visits swept as it comes, one map per UMR); a rapid sample is in air when
  its ball is above the map's air height by ``BAND`` (2 mm); nearer (or below it,
  0.05 mm tolerance: the map's node spacing) the ``sweptstock.SweptStock`` of the
  segments cut before and of this segment's cutting chains before the rapid decides
  (cuts of other UMRs; stock between the map's nodes);
* **five-axis segment** (``five_axis_rapids``): the ``SweptStock`` of its own
  cutting chains (ball and tool cylinder along the varying axis).

Rapid moves are sampled every 0.5 mm (centre and axis linear). The swept-stock test
asks for ``sweptstock.KEPT_CLEARANCE`` (0.125 mm) around the ball: what the planners'
descents guarantee between the poses they test at ``RAPID_CLEARANCE`` (0.25 mm) every
0.25 mm; asking the full 0.25 mm at other sample heights flagged a descent of the
nine_blade plan whose ball kept between 0.125 and 0.25 mm from the stock.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.roughing.plan import Segment
from cam.roughing.stock import Blank
from cam.roughing.stockmap import ZMap, sample_moves
from cam.roughing.sweptstock import KEPT_CLEARANCE, SweptStock
from cam.roughing.umr import UMR
from postproc.toolpath import MoveKind

__all__ = ["cut_chains", "five_axis_rapids", "fixed_axis_rapids", "rapid_checks"]

#: Tolerance of the Z-map air test, mm.
TOLERANCE = 0.05
#: Rapid samples less than this above the Z-map's air height are asked of the swept
#: stock too, mm: the map misses a wedge of stock between its nodes where a face
#: lies almost along the axis (a splitter plunge came down 0.27 mm into the blank's
#: inlet face that way, under UMR 1's almost radial axis).
BAND = 2.0


def cut_chains(segment: Segment, radius: float) -> tuple[list[NDArray[np.float64]],
                                                         list[NDArray[np.float64]],
                                                         NDArray[np.int64]]:
    """Ball centres and axes of a segment's chains of non-rapid moves (each with its
    start pose), and the pose index where each chain starts."""
    c = segment.tip + radius * segment.axis
    rapid = np.concatenate([[True], segment.kind[1:] == MoveKind.RAPID])
    edges = np.flatnonzero(np.diff(np.concatenate([[0], (~rapid).astype(np.int8), [0]])))
    pairs = [(a - 1, b) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return ([c[a:b] for a, b in pairs], [segment.axis[a:b] for a, b in pairs],
            np.array([a for a, _ in pairs], dtype=np.int64))


def _rapid_samples(c: NDArray[np.float64], kind: NDArray[np.int8]
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    pts, owner = sample_moves(c)
    sel = kind[owner] == MoveKind.RAPID
    return pts[sel], owner[sel]


def five_axis_rapids(segment: Segment, blank: Blank, radius: float, reach: float
                     ) -> tuple[int, int]:
    """Rapid moves of a segment with a sample in stock, and rapid moves checked."""
    runs, axes, starts = cut_chains(segment, radius)
    swept = SweptStock(blank, radius, reach, runs, axes, clearance=KEPT_CLEARANCE)
    c = segment.tip + radius * segment.axis
    pts, owner = _rapid_samples(c, segment.kind)
    bad: set[int] = set()
    for move in np.unique(owner).tolist():
        sel = owner == move
        before = int(np.searchsorted(starts, move, side="left"))
        if not swept.air(pts[sel], before).all():
            bad.add(move)
    return len(bad), int(np.sum(segment.kind[1:] == MoveKind.RAPID))


def umr_zmap(segments: list[Segment], umr: UMR, blank_triangles: NDArray[np.float64],
             radius: float, margin: float = 40.0) -> ZMap:
    """A fresh Z-map of the blank in ``umr``'s frame over the XY extent of ``segments``
    (ball centres) plus ``margin`` mm."""
    frame = umr.frame
    local = frame.to_frame(np.concatenate([s.tip + radius * s.axis for s in segments]))
    lo = local[:, :2].min(axis=0) - margin
    hi = local[:, :2].max(axis=0) + margin
    return ZMap(lo, hi, blank_triangles @ frame.matrix.T, radius)


def fixed_axis_rapids(segment: Segment, umr: UMR, prior: list[Segment], blank: Blank,
                      blank_triangles: NDArray[np.float64], radius: float, reach: float,
                      zmap: ZMap | None = None) -> tuple[int, int, float]:
    """Rapid moves of a 3+2 segment with a sample in stock (see module docstring).

    ``zmap``: the UMR's Z-map with its earlier visits' cuts already swept in (it is
    swept with this segment's cuts too); default a fresh one of the blank.
    Returns the bad moves, the rapid moves checked and the deepest intrusion into the
    Z-map's stock of a rapid sample that the swept-stock test had to clear, mm.
    """
    frame = umr.frame
    local = frame.to_frame(segment.tip + radius * segment.axis)
    if zmap is None:
        zmap = umr_zmap([segment], umr, blank_triangles, radius)
    runs, axes, starts = cut_chains(segment, radius)
    old_r: list[NDArray[np.float64]] = []
    old_a: list[NDArray[np.float64]] = []
    for p in prior:
        r, a, _ = cut_chains(p, radius)
        old_r += r
        old_a += a
    swept = SweptStock(blank, radius, reach, old_r + runs, old_a + axes,
                       [-1] * len(old_r) + list(range(len(runs))), clearance=KEPT_CLEARANCE)
    rapid = np.concatenate([[True], segment.kind[1:] == MoveKind.RAPID])
    edges = np.flatnonzero(np.diff(np.concatenate([[-1], rapid.astype(np.int8), [-1]])))
    bad: set[int] = set()
    depth = -np.inf
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if not rapid[a]:
            zmap.sweep(local[a - 1:b])  # the cutting chain with its start pose
            continue
        lo = max(a, 1)
        if lo >= b:
            continue
        pts, owner = sample_moves(local[lo - 1:b])
        owner = owner + lo - 1
        dip = zmap.air_height(pts, conservative=False) - pts[:, 2]
        over = np.flatnonzero(dip > TOLERANCE)
        if len(over):
            depth = max(depth, float(dip[over].max()))
        near = np.flatnonzero(dip > -BAND)
        for move in np.unique(owner[near]).tolist():
            sel = near[owner[near] == move]
            before = int(np.searchsorted(starts, move, side="left"))
            if not swept.air(frame.to_world(pts[sel]), before).all():
                bad.add(move)
    return len(bad), int(np.sum(segment.kind[1:] == MoveKind.RAPID)), depth


def rapid_checks(segments: list[Segment], baseline: list[Segment], umrs: list[UMR],
                 blank: Blank, blank_triangles: NDArray[np.float64], radius: float,
                 reach: float) -> dict[str, Any]:
    """Both plans' rapid moves of passage 0 against the stock (``rough.json`` fields).

    ``reach``: the tool's cylinder above the ball centre (stick-out - R), mm.
    """
    by_index = {u.index: u for u in umrs}
    first = [s for s in segments if s.passage == 0]
    # one Z-map per UMR, carried over its visits (as the planner's)
    maps = {u: umr_zmap([s for s in first if s.umr == u], by_index[u], blank_triangles,
                        radius) for u in {s.umr for s in first}}
    done: list[Segment] = []
    bad3 = moves3 = 0
    for s in first:
        bad, n, _ = fixed_axis_rapids(s, by_index[s.umr], done, blank, blank_triangles,
                                      radius, reach, maps[s.umr])
        bad3, moves3 = bad3 + bad, moves3 + n
        done.append(s)
    bad5 = moves5 = 0
    for b in baseline:
        if b.passage != 0:
            continue
        bad, n = five_axis_rapids(b, blank, radius, reach)
        bad5, moves5 = bad5 + bad, moves5 + n
    return {"rapids_in_stock": {"3axis": bad3, "5axis": bad5},
            "rapid_moves_checked": {"3axis": moves3, "5axis": moves5}}
