"""A finished pass cut into its clean runs: postures that break a rule are left out.

After the M3 procedure (``plan.finish_path``: remedy and posture repair) a pass may
still hold postures that interfere (the part, the in-process stock or the machine:
whatever the collision scene holds; the posture or the motion from it) or break the
normal-angle or lead/tilt rule. Such postures are never cut:

* the pass is shortened at either end past its offending postures (``finish_trimmed``,
  at most ``TRIM_ROUNDS`` times, never below half its points);
* postures still offending inside it are left out and the pass is cut into the runs
  between them (each of at least ``MIN_PIECE`` points); a run keeps the pass plan's
  postures when they are clean checked on their own (``kept_run``), else it is
  finished again and kept only if it is clean (a run that offends again is cut once
  more: ``_recovered``);
* the clean runs of what the trimming cut off either end (in the whole pass's plan)
  likewise become pieces of their own, kept only if clean.

The pieces are named ``<name>.<k>`` (``PathResult.piece_of`` names the pass; order.py
enters each piece after the first from the air), and every point left out is listed
in finish.json's ``cut_short`` (``cut_short_entry``); a pass with no clean piece left
is dropped (``"dropped": true``). What they leave shows in the verification.
Used by every point-milling operation: junction, blade and hub (``plan``), edge and
fillet (``edge_plan``, ``fillet_plan``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from cam.finishing.interference import StepHint
from cam.finishing.kept_run import kept_run
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, subset_path
from cam.finishing.plan import PathResult, finish_path, tail_end
from cam.finishing.stock_clearance import STOCK_ROLE, stock_blocks
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["MIN_PIECE", "TRIM_ROUNDS", "cut_short_entry", "finish_pieces",
           "finish_runs",
           "finish_trimmed", "kept_pieces", "offenders", "PassTrim", "trimmed_passes"]

#: A pass is shortened at its ends at most this many times.
TRIM_ROUNDS = 3
#: Fewest points of a piece of a pass cut at postures breaking a rule.
MIN_PIECE = 2

Accept = Callable[[PathResult], bool] | None


def offenders(result: PathResult) -> NDArray[np.intp]:
    """Postures of a finished path that still interfere (posture, or the motion from
    it to the next) or break a rule, sorted."""
    return np.union1d(result.interference.interfering_points, result.rule_points)


def _piece(path: CutterPath, index: NDArray[np.intp]) -> CutterPath:
    """The points ``index`` of ``path`` as a pass of their own, finished as they are (an
    open-ended pass's tail is cut once, by ``finish_path`` on the whole pass)."""
    return replace(subset_path(path, index), open_end=False)


def _trimmed(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
             options: FinishOptions, surfaces: ImpellerSurfaces | None,
             hint: StepHint | None = None
             ) -> tuple[PathResult, NDArray[np.intp], NDArray[np.intp], PathResult]:
    """``finish_trimmed``, the indices (into ``path``) of the points it kept, the
    offending postures of the whole pass's plan (an open-ended pass's tail that
    ``finish_path`` cut counts as offending) and that plan."""
    result = finish_path(path, tool, kins, scene, options, surfaces, hint)
    plan = result
    length = len(path)
    whole = np.union1d(offenders(result),
                       np.arange(len(result.path), length, dtype=np.intp))
    kept = np.arange(len(result.path), dtype=np.intp)
    for _ in range(TRIM_ROUNDS):
        bad = offenders(result)
        if not bad.size:
            break
        size = len(result.path)
        head, tail = bad[bad < size // 2], bad[bad >= size // 2]
        first = int(head.max()) + 1 if head.size else 0
        last = tail_end(result, tail)
        if last - first < max(2, (length + 1) // 2):
            break
        keep = np.arange(first, last, dtype=np.intp)
        kept = kept[keep]
        result = finish_path(_piece(result.path, keep), tool, kins, scene, options,
                             surfaces)
    result.trimmed = length - len(result.path)
    return result, kept, whole, plan


def finish_trimmed(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                   options: FinishOptions, surfaces: ImpellerSurfaces | None) -> PathResult:
    """``finish_path``, then shortened at either end where postures break a rule.

    Offending postures in the first half move the start past the last of them, those
    in the second half the end before the first of them (after the start of an
    interfering motion: ``plan.tail_end``); finished again (at most
    ``TRIM_ROUNDS`` times, while at least half the points remain). ``trimmed`` is
    the number of points cut.
    """
    return _trimmed(path, tool, kins, scene, options, surfaces)[0]


def _runs(good: NDArray[np.bool_]) -> list[NDArray[np.intp]]:
    """Index runs of consecutive True entries with at least ``MIN_PIECE`` points."""
    edges = np.flatnonzero(np.diff(np.r_[False, good, False].astype(np.int8)))
    return [np.arange(a, b, dtype=np.intp) for a, b in zip(edges[::2], edges[1::2], strict=True)
            if b - a >= MIN_PIECE]


def kept_pieces(path: CutterPath, keep: NDArray[np.bool_]) -> list[CutterPath]:
    """The runs of the points ``keep`` of a pass as passes of their own.

    A pass another operation cuts in part (the blade passes beside the swarf band,
    ``swarf_plan.point_passes_left``) keeps its runs of at least ``MIN_PIECE``
    points (a lone point takes its next neighbour), named ``<name>.s<k>``; each is
    finished and machined like a pass (``trimmed_passes`` orders them).

    Parameters
    ----------
    path : CutterPath
    keep : (n,) bool

    Returns
    -------
    list of CutterPath
        In the pass's order; empty when nothing is kept, ``[path]`` when everything is.
    """
    keep = np.array(keep, dtype=bool, copy=True)
    if keep.all():
        return [path]
    lone = keep & ~np.r_[False, keep[:-1]] & ~np.r_[keep[1:], False]
    index = np.flatnonzero(lone)
    keep[np.where(index + 1 < len(keep), index + 1, index - 1)] = True
    return [replace(_piece(path, run), name=f"{path.name}.s{k + 1}")
            for k, run in enumerate(_runs(keep))]


class PassTrim(Protocol):
    """What another operation leaves of the passes (``swarf_plan.PointPassTrim``)."""

    def __call__(self, path: CutterPath) -> NDArray[np.bool_] | None:
        """The (n,) bool mask of the points of ``path`` to machine; None for all."""

    def region(self, piece: CutterPath) -> int:
        """The region of the part left that a piece lies in (-1: it spans several)."""


def trimmed_passes(base: list[CutterPath], trim: PassTrim
                   ) -> tuple[list[CutterPath], dict[str, int]]:
    """Passes cut to what ``trim`` keeps, the pieces ordered region by region.

    Each pass kept in part becomes its runs (``kept_pieces``), each machined as a pass
    of its own. The blade passes of a wall are then ordered passes whole and pieces
    spanning several regions first, then the pieces region by region (each in the
    passes' order): neighbouring pieces one stepover apart follow each other (short
    links, zig-zag) instead of every pass hopping over the other operation's band.

    Parameters
    ----------
    base : list of CutterPath
        Passage 0's passes, planning order.
    trim : PassTrim

    Returns
    -------
    paths : list of CutterPath
    counts : dict
        ``blade_points`` planned and ``blade_points_kept``; blade passes
        ``passes_whole``, ``passes_cut``, ``passes_left_out``.
    """
    out: list[tuple[tuple[int, ...], CutterPath]] = []
    walls: dict[str, int] = {}
    counts = {"blade_points": 0, "blade_points_kept": 0, "passes_whole": 0,
              "passes_cut": 0, "passes_left_out": 0}
    for i, path in enumerate(base):
        mask = trim(path)
        pieces = [path] if mask is None else kept_pieces(path, mask)
        whole = len(pieces) == 1 and pieces[0] is path
        if path.operation == "blade":
            counts["blade_points"] += len(path)
            counts["blade_points_kept"] += sum(len(p) for p in pieces)
            counts["passes_whole" if whole else
                   "passes_cut" if pieces else "passes_left_out"] += 1
        if path.operation != "blade" or path.wall is None:
            out += [((i,), p) for p in pieces]
            continue
        wall = walls.setdefault(path.wall.label, i)  # the wall's first pass's place
        out += [((wall, -1 if whole else trim.region(p), i), p) for p in pieces]
    out.sort(key=lambda item: item[0])
    return [p for _, p in out], counts


def _recovered(path: CutterPath, index: NDArray[np.intp], tool: Tool, kins: Kinematics,
               scene: CollisionScene, options: FinishOptions,
               surfaces: ImpellerSurfaces | None, accept: Accept,
               larger: tuple[PathResult, NDArray[np.intp]] | None = None
               ) -> list[tuple[NDArray[np.intp], PathResult]]:
    """Clean pieces of the points ``index`` of ``path`` (a run of postures found clean
    in a larger plan).

    The run keeps the larger plan's postures when they pass every check on their own
    (``larger``: that plan and the run's indices into its path; ``kept_run``).
    Otherwise it is finished on its own; where postures still break a rule it is cut
    there once more and the runs between are finished again. Only pieces that keep
    every rule (and that ``accept``, when given) are returned, with their indices into
    ``path``: a piece adds cut, never an offence.
    """
    def clean(piece: PathResult) -> bool:
        return not offenders(piece).size and (accept is None or accept(piece))

    if len(index) < MIN_PIECE:
        return []
    if larger is not None:
        kept = kept_run(larger[0], larger[1], tool, scene, options, surfaces)
        if clean(kept):
            return [(index, kept)]
    result = finish_path(_piece(path, index), tool, kins, scene, options, surfaces)
    bad = offenders(result)
    if not bad.size:
        return [(index, result)] if clean(result) else []
    good = np.ones(len(index), dtype=bool)
    good[bad] = False
    out = []
    for run in _runs(good):
        piece = finish_path(_piece(path, index[run]), tool, kins, scene, options,
                            surfaces)
        if clean(piece):
            out.append((index[run], piece))
    return out


def finish_runs(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                options: FinishOptions, surfaces: ImpellerSurfaces | None,
                accept: Accept = None, hint: StepHint | None = None,
                causes: list[str | None] | None = None
                ) -> tuple[list[PathResult], NDArray[np.intp]]:
    """The clean pieces of a pass (module docstring) and the indices (into ``path``)
    of the points left out, sorted.

    Parameters
    ----------
    path : CutterPath
    tool, kins, scene, options, surfaces
        As ``plan.finish_path``.
    accept : callable, optional
        A further test a piece recovered from a trimmed end must pass (the edge
        passes' least lean off the surface, ``edge_plan``).
    hint : StepHint, optional
        The same pass's remedy step in another passage (``plan.finish_path``).
    causes : list, optional
        Filled with what each point left out meets in the whole pass's plan (its
        posture's ``hit_role``: a design face's role, ``"stock"``, ``"machine"``;
        ``"stock"`` also where shank or holder come too close to the excess stock,
        at the posture or on the motion from it; None: a rule, a design clearance, a
        motion or an open end's tail; ``_causes``), one per ``lost`` point.

    Returns
    -------
    pieces : list of PathResult
        Machining order; none of them interferes or breaks a rule. One piece named as
        the pass when nothing was left out; empty when nothing clean is left.
    lost : (k,) intp
        Points of ``path`` left out.
    """
    result, kept, whole, plan = _trimmed(path, tool, kins, scene, options, surfaces, hint)
    bad = offenders(result)
    pieces = [(kept, result)]
    if bad.size:
        good = np.ones(len(result.path), dtype=bool)
        good[bad] = False
        pieces = [found for run in _runs(good)
                  for found in _recovered(path, kept[run], tool, kins, scene, options,
                                          surfaces, None, (result, run))]
    # the clean runs (in the whole pass's plan) of each end the trimming cut off
    clean = np.ones(len(path), dtype=bool)
    clean[whole] = False
    ends: list[list[tuple[NDArray[np.intp], PathResult]]] = [[], []]
    for side, cut in enumerate((np.arange(0, int(kept[0]), dtype=np.intp),
                                np.arange(int(kept[-1]) + 1, len(path), dtype=np.intp))):
        for run in _runs(clean[cut]):
            ends[side] += _recovered(path, cut[run], tool, kins, scene, options, surfaces,
                                     accept, (plan, cut[run]))
    pieces = ends[0] + pieces + ends[1]
    covered = np.concatenate([index for index, _ in pieces] or [np.zeros(0, np.intp)])
    lost = np.setdiff1d(np.arange(len(path), dtype=np.intp), covered)
    results = [piece for _, piece in pieces]
    if len(results) > 1:
        results = [_renamed(piece, f"{path.name}.{k + 1}", path.name)
                   for k, piece in enumerate(results)]
    for piece in results:
        piece.trimmed = 0
    if results:
        results[0].trimmed = len(path) - sum(len(piece.path) for piece in results)
    if causes is not None:
        causes[:] = _causes(plan, lost, tool, scene, options)
    return results, lost


def _causes(plan: PathResult, lost: NDArray[np.intp], tool: Tool, scene: CollisionScene,
            options: FinishOptions) -> list[str | None]:
    """What each point ``lost`` meets in the whole pass's plan ``plan``: the role its
    posture touches (``hit_role``), else ``"stock"`` where the excess stock blocks
    its shank or holder (posture, or the motion from it: a clearance, not a contact,
    so no role; ``stock_clearance.stock_blocks``), else None (a rule, a design
    clearance, the motion, an open end's tail)."""
    roles = plan.interference.hit_role
    out = [roles[i] if i < len(roles) else None for i in lost.tolist()]
    ask = np.array([i for i, role in zip(lost.tolist(), out, strict=True)
                    if role is None and i < len(roles)], dtype=np.intp)
    if ask.size:
        blocked = stock_blocks(scene, tool, plan.tip, plan.axis, ask,
                               options.cutter_allowance_mm, options.clearance_mm,
                               options.motion_step_mm, options.motion_step_deg)
        stock = set(ask[blocked].tolist())
        out = [STOCK_ROLE if i in stock else role
               for i, role in zip(lost.tolist(), out, strict=True)]
    return out


def _renamed(result: PathResult, name: str, whole: str) -> PathResult:
    """``result`` with its path renamed ``name`` (a piece of the pass ``whole``)."""
    result.path = replace(result.path, name=name)
    result.piece_of = whole
    return result


def finish_pieces(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                  options: FinishOptions, surfaces: ImpellerSurfaces | None
                  ) -> list[PathResult]:
    """The clean pieces of ``finish_runs``.

    On nine_blade the fillet pass touching the blade contact round the suction side's
    cut trailing-edge corner ran 0.34 mm into the built solid's fillet there at 4 of
    its 11 postures (the ball lies inside the rolling ball of the closed-form fillet,
    which the solid's interpolated fillet face leaves by that much at the corner): no
    tilt frees a ball that cuts the part.

    On the splitter fixture the suction-side fillet passes round the splitter's leading
    edge (ball4_taper, 2.5 mm shank clearance) break the clearance at postures 2-3 of 8
    only (the shank's foot, 10 mm up the axis, 2.03-2.24 mm from the splitter's own
    leading edge); trimming kept postures 5-7 and left up to 0.58 mm on the fillet
    there (507 of 37,500 fillet samples over the 0.4 mm scallop); with postures 0-1
    kept as well the passage's passes leave at most 0.36 mm (p99 0.24 mm) on that
    fillet, none over the scallop.
    """
    return finish_runs(path, tool, kins, scene, options, surfaces)[0]


def cut_short_entry(path: CutterPath, lost: NDArray[np.intp],
                    causes: list[str | None] | None = None) -> dict[str, Any]:
    """finish.json's record of the points of a pass that were left out (``cut_short``):
    the pass, their indices in it, their ball centres (mm) and blade parameter u;
    ``dropped``: nothing of the pass is cut; ``causes`` (when given, ``finish_runs``):
    what each meets."""
    entry = {"path": path.name, "operation": path.operation, "points": len(path),
             "left_out": lost.tolist(), "dropped": len(lost) == len(path),
             "centres_mm": np.round(path.centre[lost], 3).tolist(),
             "curve_u": np.round(path.curve_u[lost], 4).tolist()}
    if causes is not None:
        entry["causes"] = list(causes)
    return entry
