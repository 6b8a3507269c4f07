"""Interference check and the paper's remedy (M3 steps 3 and 6-8, eq. 7).

A posture *interferes* when any tool part (the ball shrunk by the cutter
allowance, the flutes, the neck/shank, the holder) touches the part, or when the
shank and holder come closer than the required clearance. The motion between
consecutive postures is checked by subdivision (``CollisionScene.check_motion``);
its bound (how much closer the tool may come between sub-samples than reported)
is reported with the result.

Remedy: increase the C angle by dC, step by step, "away from the blade", and
recompute the tool tips so the ball centre stays on its path; stop at the first
step with no interference. The turn is applied to the whole path at once: a
constant C offset rotates every axis about the impeller axis, leaves A unchanged
and adds the same constant to every C, so it cannot bring back a reverse movement.
The total turn may not exceed ``Cmax`` (eq. 7, the smallest over the path). When
the path still interferes at Cmax, the tool is too large for it: the result says
"smaller tool needed" and names the points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.finishing.options import FinishOptions
from cam.finishing.posture import rotate_about_z
from cam.tools import Tool

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from cam.collision.scene import PostureReport

__all__ = [
    "InterferenceResult",
    "StepHint",
    "check_path",
    "first_interference",
    "interferes_at",
    "resolve_interference",
]

Array = NDArray[np.float64]


@dataclass
class InterferenceResult:
    """Collision state of one path's postures.

    Attributes
    ----------
    tip, axis : (n, 3) float64
        Final postures (after any C increase).
    delta_c : float
        C increase applied to the whole path, rad (0 when none was needed).
    steps : int
        Remedy steps tried.
    collides : (n,) bool
        Posture touches the part or the shank/holder clearance is below the limit.
    motion_collides : (n - 1,) bool
        Same for the motion between posture i and i + 1 (sub-sampled).
    clearance : (n,) float64
        Shank and holder clearance per posture, mm (NaN for a bare cutter); exact up
        to ``options.clearance_exact_mm``, a lower bound above it.
    hit_role : list of (str or None)
        Part role touched first per posture.
    motion_bound : float
        The tool may come this much closer to the part between motion sub-samples
        than the motion check reports, mm.
    c_max : float
        Largest C increase eq. 7 allows on this path, rad.
    checks : dict
        Check counts of the collision service.
    witnesses : (steps,) intp
        Of a free result: per remedy step below the free one, a posture whose check
        (posture, or motion from it) interfered (``StepHint``).
    """

    tip: Array
    axis: Array
    delta_c: float
    steps: int
    collides: NDArray[np.bool_]
    motion_collides: NDArray[np.bool_]
    clearance: Array
    hit_role: list[str | None]
    motion_bound: float
    c_max: float
    checks: dict[str, int] = field(default_factory=dict)
    witnesses: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))

    @property
    def interfering_points(self) -> NDArray[np.intp]:
        """Indices of postures (or of motion starts) that still interfere."""
        bad = self.collides.copy()
        bad[:-1] |= self.motion_collides
        return np.asarray(np.flatnonzero(bad), dtype=np.intp)

    @property
    def smaller_tool_needed(self) -> bool:
        """True when the path still interferes at Cmax."""
        return bool(self.interfering_points.size)


def _posture_report(scene: CollisionScene, tool: Tool, tip: Array, axis: Array,
                    options: FinishOptions) -> PostureReport:
    """``check_path``'s check of the postures alone."""
    return scene.check_postures(tool, tip, axis, cutter_allowance=options.cutter_allowance_mm,
                                clearance_cap=options.clearance_exact_mm,
                                clearance_limits=(options.clearance_mm,))


def _posture_bad(report: PostureReport, options: FinishOptions) -> NDArray[np.bool_]:
    """Postures in contact or with shank/holder closer than ``clearance_mm``."""
    clearance = np.asarray(report.clearance, dtype=np.float64)
    return np.asarray(report.collides, dtype=bool) | (
        np.isfinite(clearance) & (clearance < options.clearance_mm))


def check_path(scene: CollisionScene, tool: Tool, tip: Array, axis: Array,
               options: FinishOptions, postures: PostureReport | None = None
               ) -> InterferenceResult:
    """Check the postures and the motion between them (no remedy).

    ``postures``: the postures' check already made (``_posture_report`` of the same
    postures), reused as is.
    """
    report = postures if postures is not None else _posture_report(scene, tool, tip, axis,
                                                                   options)
    clearance = np.asarray(report.clearance, dtype=np.float64)
    collides = _posture_bad(report, options)
    if len(tip) > 1:
        motion = scene.check_motion(tool, tip, axis, max_step_mm=options.motion_step_mm,
                                    max_step_deg=options.motion_step_deg,
                                    cutter_allowance=options.cutter_allowance_mm,
                                    # only compared with the limit: exact below it
                                    clearance_cap=options.clearance_mm,
                                    clearance_limits=(options.clearance_mm,),
                                    ends=report)  # the postures are checked above
        mclear = np.asarray(motion.clearance, dtype=np.float64)
        motion_collides = np.asarray(motion.collides, dtype=bool) | (
            np.isfinite(mclear) & (mclear < options.clearance_mm))
        bound = float(motion.bound)
    else:
        motion_collides = np.zeros(0, dtype=bool)
        bound = 0.0
    checks = {"postures": len(tip), **{f"posture_{k}": int(v) for k, v in report.checks.items()}}
    return InterferenceResult(tip, axis, 0.0, 0, collides, motion_collides, clearance,
                              list(report.hit_role), bound, math.inf, checks)


def resolve_interference(scene: CollisionScene, tool: Tool, centre: Array, axis: Array,
                         sign: float, c_max: Array, options: FinishOptions,
                         hint: StepHint | None = None) -> InterferenceResult:
    """Check a path and, if it interferes, raise C by dC steps up to Cmax (eq. 7).

    Parameters
    ----------
    centre : (n, 3) float64
        Ball centres (kept: tips are ``centre - R axis``).
    axis : (n, 3) float64
        Unit tool axes before the remedy.
    sign : float
        Sense of "away from the blade" about +Z (+1 / -1).
    c_max : (n,) float64
        Eq. 7 per point, rad; the path's limit is the smallest.
    hint : StepHint, optional
        The answer on a congruent path (the same path in another passage). It is
        only used as a guess that is proven before it is taken: every step below
        its free step must still interfere at its witness, and its free step must
        be free in a full check. Then that step is the first free one, exactly
        what the search without the hint returns; otherwise the search runs.

    Returns
    -------
    InterferenceResult
        The first interference-free step, or (still interfering) the step with the
        fewest interfering postures up to Cmax.
    """
    limit = float(np.min(c_max))
    step = math.radians(options.delta_c_deg)
    if hint is not None and hint.points == len(centre) and \
            hint.free_step * step <= limit + 1e-12:
        taken = _take_hint(scene, tool, centre, axis, sign, step, hint, options)
        if taken is not None:
            taken.c_max = limit
            return taken
    return _search(scene, tool, centre, axis, sign, step, limit, options)


@dataclass(frozen=True)
class StepHint:
    """What ``resolve_interference`` found on a path, as a guess for a congruent one.

    Attributes
    ----------
    free_step : int
        The first free remedy step k (C turned by ``k dC``; 0: none needed).
    witnesses : (free_step,) intp
        Per step below it, a posture whose check (the posture, or the motion from
        it to the next) interfered.
    points : int
        Postures of the path (a hint is only tried on a path of this length).
    """

    free_step: int
    witnesses: tuple[int, ...]
    points: int

    @classmethod
    def of(cls, result: InterferenceResult) -> StepHint | None:
        """The hint of a free result (None when no step was free)."""
        if result.smaller_tool_needed or len(result.witnesses) != result.steps:
            return None
        return cls(result.steps, tuple(int(w) for w in result.witnesses), len(result.tip))


def _turned(axis: Array, sign: float, k: int, step: float) -> Array:
    return axis if k == 0 else rotate_about_z(axis, sign * k * step)


def _take_hint(scene: CollisionScene, tool: Tool, centre: Array, axis: Array, sign: float,
               step: float, hint: StepHint, options: FinishOptions
               ) -> InterferenceResult | None:
    """The result of step ``hint.free_step`` if the hint is proven, else None.

    The witness postures of all lower steps are checked in one call; a step whose
    witness posture is clear is then checked as ``first_interference`` does (the
    motion from the witness).
    """
    radius = tool.radius
    witnesses = np.asarray(hint.witnesses, dtype=np.intp)
    if witnesses.size:
        # the rows of each step's whole turned path (the very postures of a full check)
        rows = np.stack([_turned(axis, sign, k, step)[w]
                         for k, w in enumerate(witnesses.tolist())])
        report = scene.check_postures(tool, centre[witnesses] - radius * rows, rows,
                                      cutter_allowance=options.cutter_allowance_mm,
                                      clearance_cap=options.clearance_mm,
                                      clearance_limits=(options.clearance_mm,))
        clear = np.asarray(report.clearance, dtype=np.float64)
        posture_bad = np.asarray(report.collides) | (np.isfinite(clear)
                                                     & (clear < options.clearance_mm))
        for k in np.flatnonzero(~posture_bad).tolist():
            turned = _turned(axis, sign, k, step)
            if first_interference(scene, tool, centre - radius * turned, turned,
                                  witnesses[k:k + 1], options) < 0:
                return None
    k = hint.free_step
    turned = _turned(axis, sign, k, step)
    trial = check_path(scene, tool, centre - radius * turned, turned, options)
    if trial.smaller_tool_needed:
        return None
    trial.delta_c, trial.steps = k * step, k
    trial.witnesses = np.asarray(hint.witnesses, dtype=np.intp)
    return trial


def _search(scene: CollisionScene, tool: Tool, centre: Array, axis: Array, sign: float,
            step: float, limit: float, options: FinishOptions) -> InterferenceResult:
    """The remedy's steps in order (``resolve_interference`` without a hint)."""
    radius = tool.radius
    best = check_path(scene, tool, centre - radius * axis, axis, options)
    best.c_max = limit
    if not best.smaller_tool_needed:
        return best

    def full(k: int) -> InterferenceResult:
        turned = _turned(axis, sign, k, step)
        trial = check_path(scene, tool, centre - radius * turned, turned, options)
        trial.delta_c, trial.steps, trial.c_max = k * step, k, limit
        return trial

    # A step that still interferes is only needed (with its count) if no step is
    # free. Each step is first probed at the postures and motions that interfered
    # at the last fully checked step (the last step's witness first): one of them
    # still interfering fails the step without checking the rest. Only a
    # free-looking step is checked in full.
    probe = best.interfering_points
    witnesses = [int(probe[0])]
    failed: list[int] = []
    k = 0
    while (k + 1) * step <= limit + 1e-12:
        k += 1
        turned = _turned(axis, sign, k, step)
        witness = first_interference(scene, tool, centre - radius * turned, turned, probe,
                                     options, first=witnesses[-1])
        if witness >= 0:
            failed.append(k)
            witnesses.append(witness)
            continue
        trial = full(k)
        if not trial.smaller_tool_needed:
            trial.witnesses = np.asarray(witnesses, dtype=np.intp)
            return trial
        probe = trial.interfering_points
        witnesses.append(int(probe[0]))
        failed.append(-k)  # checked in full: kept below
        if trial.interfering_points.size < best.interfering_points.size:
            best = trial
    # no step is free: the step with the fewest interfering postures (the first of
    # equals), as if every step had been checked in full. A step's count is at least
    # that of its interfering postures: when those alone cannot beat the best, its
    # motion is not checked (the choice is the same).
    for k_failed in failed:
        if k_failed > 0:
            turned = _turned(axis, sign, k_failed, step)
            postures = _posture_report(scene, tool, centre - radius * turned, turned, options)
            count = int(_posture_bad(postures, options).sum())
            most = best.interfering_points.size
            if count > most or (count == most and k_failed >= best.steps):
                continue
            trial = check_path(scene, tool, centre - radius * turned, turned, options,
                               postures)
            trial.delta_c, trial.steps, trial.c_max = k_failed * step, k_failed, limit
            if trial.interfering_points.size < best.interfering_points.size or (
                    trial.interfering_points.size == best.interfering_points.size
                    and trial.steps < best.steps):
                best = trial
    best.steps = k
    return best


def interferes_at(scene: CollisionScene, tool: Tool, tip: Array, axis: Array,
                  points: NDArray[np.intp], options: FinishOptions) -> bool:
    """Whether any of the postures ``points`` (or the motion from one of them to the
    next posture) interferes, with the rules of ``check_path``.

    Parameters
    ----------
    tip, axis : (n, 3) float64
        The whole path's postures.
    points : (k,) intp
        Indices of postures to test (sorted).
    """
    return first_interference(scene, tool, tip, axis, points, options) >= 0


def first_interference(scene: CollisionScene, tool: Tool, tip: Array, axis: Array,
                       points: NDArray[np.intp], options: FinishOptions,
                       first: int | None = None) -> int:
    """A posture of ``points`` that interferes (itself or the motion from it to the
    next posture, with the rules of ``check_path``), or -1 when none does.

    Parameters
    ----------
    tip, axis : (n, 3) float64
        The whole path's postures.
    points : (k,) intp
        Indices of postures to test (sorted).
    first : int, optional
        Tested alone before the others (a likely witness; the answer "some posture
        interferes" does not depend on it).

    Notes
    -----
    Clearances are only compared with ``clearance_mm`` here, so they are asked
    exact up to that (``clearance_cap``): the comparison is the one ``check_path``
    makes with its values exact up to ``clearance_exact_mm``.
    """
    if not points.size:
        return -1
    if first is not None and len(points) > 1 and np.any(points == first):
        alone = np.array([first], dtype=np.intp)
        if first_interference(scene, tool, tip, axis, alone, options) >= 0:
            return int(first)
        points = points[points != first]
    report = scene.check_postures(tool, tip[points], axis[points],
                                  cutter_allowance=options.cutter_allowance_mm,
                                  clearance_cap=options.clearance_mm,
                                  clearance_limits=(options.clearance_mm,))
    clear = np.asarray(report.clearance, dtype=np.float64)
    bad = np.asarray(report.collides) | (np.isfinite(clear) & (clear < options.clearance_mm))
    if bad.any():
        return int(points[np.argmax(bad)])
    segments = points[points < len(tip) - 1]
    if not segments.size:
        return -1
    # runs of consecutive segments, each checked as one motion
    breaks = np.flatnonzero(np.diff(segments) > 1) + 1
    for run in np.split(segments, breaks):
        lo, hi = int(run[0]), int(run[-1]) + 2
        motion = scene.check_motion(tool, tip[lo:hi], axis[lo:hi],
                                    max_step_mm=options.motion_step_mm,
                                    max_step_deg=options.motion_step_deg,
                                    cutter_allowance=options.cutter_allowance_mm,
                                    clearance_cap=options.clearance_mm,
                                    clearance_limits=(options.clearance_mm,))
        mclear = np.asarray(motion.clearance, dtype=np.float64)
        moving = np.asarray(motion.collides) | (np.isfinite(mclear)
                                                & (mclear < options.clearance_mm))
        if moving.any():
            return lo + int(np.argmax(moving))
    return -1
