"""Linking moves of a fixed-axis (3+2) region, in the region's frame (axis = +Z).

As a CAM system links a 3-axis roughing program (``ZMap`` is the stock model):

* **lift**: from a run's last point a short feed move ``lift`` mm up the axis (the
  cutter leaves the cut at feed), then rapid;
* **link height**: the rapids climb to, cross at, and come down from the lowest
  height that keeps the ball in air and off the design along the straight XY line
  between the two runs, plus ``clearance``: the air height of the stock map
  (the blank's top, or the floor the layers above and the runs before have left)
  and the drop-cutter height of the design, sampled every ``LINK_SAMPLE`` mm.
  Between passes of a layer that is just above the layer above's floor, not above
  the whole blank; it never exceeds the frame's safe height;
* **approach and entry**: rapid down to ``entry_height`` above the stock at the
  entry (the stock's air height there), then **ramp** in at ``entry_angle`` (deg
  from the horizontal) along the direction of the run's first move, or **plunge**
  along -Z when the ramp would come closer than the allowance to the design
  (drop-cutter), its top would stand in stock, or the run has no direction; an
  entry angle of 90 deg always plunges. Ramps and plunges are feed moves
  (``MoveKind.PLUNGE``, cut at the plunge feed) only over that last distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.roughing.dropcutter import DropSurface
from cam.roughing.stockmap import ZMap
from postproc.toolpath import MoveKind

__all__ = ["LinkSettings", "entry_moves", "link_runs", "refine_moves"]

#: Sample spacing of link lines and ramps for the drop-cutter checks, mm.
LINK_SAMPLE = 0.5
#: Sample spacing of the feed-move refinement, mm.
REFINE_STEP = 0.25


@dataclass(frozen=True)
class LinkSettings:
    """Linking parameters (mm, deg): feed lift, link clearance above stock and design,
    approach clearance above the stock at an entry, ramp angle, safe height."""

    clearance: float = 2.0
    entry_height: float = 1.0
    entry_angle_deg: float = 15.0
    safe_height: float = math.inf
    lift: float = 1.0


def _line(a: NDArray[np.float64], b: NDArray[np.float64],
          step: float = LINK_SAMPLE) -> NDArray[np.float64]:
    n = max(2, int(math.ceil(np.linalg.norm(b[:2] - a[:2]) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a[None] + t * (b - a)[None])


def _ceiling(points: NDArray[np.float64], design: DropSurface, stock: ZMap
             ) -> NDArray[np.float64]:
    """Lowest ball-centre height in air and off the design over ``points`` (frame)."""
    return np.asarray(np.maximum(stock.air_height(points), design.drop(points)))


def entry_moves(start: NDArray[np.float64], direction: NDArray[np.float64] | None,
                design: DropSurface, stock: ZMap, settings: LinkSettings,
                lowest: float | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.int8], bool]:
    """The approach point and the feed entry onto ``start`` (frame coords).

    ``lowest``: a frame height down to which a ball coming down the axis over
    ``start`` (from the stock map's air height) is known to stay in air from another
    stock model (``SweptStock``: cuts of earlier regions); a plunge may start
    ``entry_height`` above it. Above the stock map's entry top, it raises the entry
    (that model found stock the map's nodes miss).

    Returns
    -------
    centres : (2, 3) float64
        The entry's top (reached by rapid) and ``start``.
    kinds : (2,) int8
        RAPID (to the top), PLUNGE (the ramp or plunge at the plunge feed).
    ramped : bool
    """
    above = float(_ceiling(start[None], design, stock)[0])
    z_top = max(above, float(start[2])) + settings.entry_height
    if lowest is None:
        plunge_top = z_top
    elif lowest > z_top:  # the other model finds stock where the stock map sees air
        plunge_top = z_top = lowest + settings.entry_height
    else:
        plunge_top = min(z_top, max(lowest, float(design.drop(start[None])[0]),
                                    float(start[2])) + settings.entry_height)
    if direction is not None and settings.entry_angle_deg < 90.0:
        d = np.array([direction[0], direction[1], 0.0])
        norm = np.linalg.norm(d)
        if norm > 1e-9:
            d /= norm
            slope = math.tan(math.radians(settings.entry_angle_deg))
            for _ in range(4):  # the ramp's top must be in air too: raise it until so
                if not math.isfinite(z_top):
                    break
                top = start - d * (z_top - start[2]) / slope
                top[2] = z_top
                samples = _line(top, start)
                need = max(float(_ceiling(top[None], design, stock)[0]) + settings.entry_height,
                           z_top)
                if need > z_top + 1e-9:
                    z_top = need
                    continue
                height = samples[:, 2]
                if np.all(design.drop(samples) <= height + 1e-9):
                    return (np.stack([top, start]),
                            np.array([MoveKind.RAPID, MoveKind.PLUNGE], np.int8), True)
                break
    top = np.array([start[0], start[1], plunge_top])
    return np.stack([top, start]), np.array([MoveKind.RAPID, MoveKind.PLUNGE], np.int8), False


def link_runs(end: NDArray[np.float64], start: NDArray[np.float64],
              direction: NDArray[np.float64] | None, design: DropSurface, stock: ZMap,
              settings: LinkSettings, lowest: float | None = None
              ) -> tuple[NDArray[np.float64], NDArray[np.int8], bool]:
    """Lift, rapids at the link height and entry from run end ``end`` to ``start``.

    ``stock`` must already hold the cuts up to ``end`` (see module docstring);
    ``lowest`` as in ``entry_moves``.

    Returns
    -------
    centres : (k, 3) float64
        Ball centres after ``end`` up to and including ``start``.
    kinds : (k,) int8
    ramped : bool
    """
    entry, kinds, ramped = entry_moves(start, direction, design, stock, settings, lowest)
    lifted = end + np.array([0.0, 0.0, settings.lift])
    line = _line(lifted, entry[0])
    top = max(float(np.max(_ceiling(line, design, stock))), float(lifted[2]),
              float(entry[0, 2]))
    height = max(min(top + settings.clearance, settings.safe_height), top)
    path = [lifted, np.array([lifted[0], lifted[1], height]),
            np.array([entry[0, 0], entry[0, 1], height]), entry[0]]
    lead = [MoveKind.RETRACT, MoveKind.RAPID, MoveKind.RAPID, MoveKind.RAPID]
    keep = [0] + [i for i in range(1, 4) if np.linalg.norm(path[i] - path[i - 1]) > 1e-9]
    centres = np.concatenate([np.stack([path[i] for i in keep]), entry[1:]])
    return centres, np.concatenate([np.array([lead[i] for i in keep], np.int8), kinds[1:]]), ramped


def refine_moves(centres: NDArray[np.float64], kind: NDArray[np.int8], design: DropSurface,
                 step: float = REFINE_STEP, rounds: int = 4
                 ) -> tuple[NDArray[np.float64], NDArray[np.int8], int]:
    """Insert drop-cutter points where a straight cutting move dips below the drop surface.

    Every FEED and PLUNGE move ``centres[i-1] -> centres[i]`` (frame, axis +Z) is
    sampled every ``step`` mm; the sample with the largest dip below the drop height
    is inserted at that height (same move kind), and the new moves are checked again,
    ``rounds`` times at most.

    Returns
    -------
    centres : (m, 3) float64
    kind : (m,) int8
    added : int
        Points inserted.
    """
    added = 0
    for _ in range(rounds):
        cutting = (kind == MoveKind.FEED) | (kind == MoveKind.PLUNGE)
        cutting[0] = False
        moves = np.flatnonzero(cutting)
        if not len(moves):
            break
        a, b = centres[moves - 1], centres[moves]
        n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(np.int64), 1)
        owner = np.repeat(np.arange(len(moves)), n - 1)
        if not len(owner):
            break
        first = np.repeat(np.cumsum(n - 1) - (n - 1), n - 1)
        t = (np.arange(len(owner)) - first + 1) / n[owner]
        pts = a[owner] + t[:, None] * (b - a)[owner]
        dip = design.drop(pts) - pts[:, 2]
        bad = dip > 1e-9
        if not bad.any():
            break
        idx = np.flatnonzero(bad)
        idx = idx[np.lexsort((-dip[idx], owner[idx]))]  # by move, largest dip first
        idx = idx[np.concatenate([[True], owner[idx][1:] != owner[idx][:-1]])]
        fix = owner[idx]
        new = pts[idx].copy()
        new[:, 2] += dip[idx]
        centres = np.insert(centres, moves[fix], new, axis=0)
        kind = np.insert(kind, moves[fix], kind[moves[fix]])
        added += len(fix)
    return centres, kind, added
