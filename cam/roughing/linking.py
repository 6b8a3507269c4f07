"""Linking moves of a fixed-axis (3+2) region, in the region's frame (axis = +Z).

Between two cutting runs: **retract** along +Z at feed until the ball is clear of the
blank (``clear_height``), rapid up to the link height, **rapid** across
at that height to above the next run, rapid down to ``entry_height`` above its first
point, then **ramp** in at ``entry_angle`` (deg from the horizontal) along the
direction of the run's first move, or **plunge** along -Z when the ramp would come
closer than the allowance to the design (checked with the drop-cutter) or the run's
first move is not long enough to give a direction. An entry angle of 90 deg always
plunges. The link height is the highest point of the drop-cutter surface of the
design plus the blank envelope along the straight XY line between the two runs, plus
``clearance``; it never exceeds the frame's safe height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.roughing.dropcutter import DropCutter
from postproc.toolpath import MoveKind

__all__ = ["LinkSettings", "entry_moves", "link_runs", "refine_moves"]

#: Sample spacing of link lines and ramps for the drop-cutter checks, mm.
LINK_SAMPLE = 1.0
#: Sample spacing of the feed-move refinement, mm.
REFINE_STEP = 0.25


@dataclass(frozen=True)
class LinkSettings:
    """Linking parameters (mm, deg)."""

    clearance: float = 2.0
    entry_height: float = 2.0
    entry_angle_deg: float = 15.0
    safe_height: float = math.inf


def _line(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    n = max(2, int(math.ceil(np.linalg.norm(b[:2] - a[:2]) / LINK_SAMPLE)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a[None] + t * (b - a)[None])


def entry_moves(start: NDArray[np.float64], direction: NDArray[np.float64] | None,
                design: DropCutter, settings: LinkSettings
                ) -> tuple[NDArray[np.float64], NDArray[np.int8], bool]:
    """Ball centres and move kinds from above ``start`` down onto it (frame coords).

    Returns
    -------
    centres : (k, 3) float64
    kinds : (k,) int8
        RAPID to the entry point, then PLUNGE (feed) moves.
    ramped : bool
    """
    above = start + np.array([0.0, 0.0, settings.entry_height])
    if direction is not None and settings.entry_angle_deg < 90.0:
        d = np.array([direction[0], direction[1], 0.0])
        norm = np.linalg.norm(d)
        if norm > 1e-9:
            run = settings.entry_height / math.tan(math.radians(settings.entry_angle_deg))
            ramp_top = start - d / norm * run + np.array([0.0, 0.0, settings.entry_height])
            samples = _line(ramp_top, start)
            floor = design.drop(samples)
            if np.all(floor <= samples[:, 2] + 1e-9):
                return (np.stack([ramp_top, start]),
                        np.array([MoveKind.RAPID, MoveKind.PLUNGE], np.int8), True)
    return np.stack([above, start]), np.array([MoveKind.RAPID, MoveKind.PLUNGE], np.int8), False


def link_runs(end: NDArray[np.float64], start: NDArray[np.float64],
              direction: NDArray[np.float64] | None, design: DropCutter,
              envelope: DropCutter, settings: LinkSettings, clear_height: float = -math.inf
              ) -> tuple[NDArray[np.float64], NDArray[np.int8], bool]:
    """Retract, rapid and entry from run end ``end`` to run start ``start`` (frame).

    The retract is a feed move up to ``clear_height`` (the ball clear of the blank,
    frame z) and a rapid above it.

    Returns
    -------
    centres : (k, 3) float64
        Ball centres after ``end`` up to and including ``start``.
    kinds : (k,) int8
    ramped : bool
    """
    entry, kinds, ramped = entry_moves(start, direction, design, settings)
    line = np.concatenate([_line(end, entry[0]), _line(entry[0], start)])
    top = max(float(np.max(design.drop(line))), float(np.max(envelope.drop(line))),
              float(end[2]), float(entry[0, 2]))
    height = min(top + settings.clearance, settings.safe_height)
    height = max(height, float(end[2]), float(entry[0, 2]))
    up = np.array([end[0], end[1], height])
    over = np.array([entry[0, 0], entry[0, 1], height])
    out_z = min(clear_height, height)
    if out_z >= height - 1e-9:  # fed all the way up
        centres = np.concatenate([up[None], over[None], entry])
        lead = np.array([MoveKind.RETRACT, MoveKind.RAPID], np.int8)
    elif out_z > float(end[2]) + 1e-9:  # fed out of the blank, then rapid
        fed = np.array([end[0], end[1], out_z])
        centres = np.concatenate([fed[None], up[None], over[None], entry])
        lead = np.array([MoveKind.RETRACT, MoveKind.RAPID, MoveKind.RAPID], np.int8)
    else:  # already clear of the blank
        centres = np.concatenate([up[None], over[None], entry])
        lead = np.array([MoveKind.RAPID, MoveKind.RAPID], np.int8)
    return centres, np.concatenate([lead, kinds]), ramped


def refine_moves(centres: NDArray[np.float64], kind: NDArray[np.int8], design: DropCutter,
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
