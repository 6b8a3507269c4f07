"""The fillet and edge finishing operations: the fillet tool and the finished paths.

* ``choose_fillet_tool``: the largest ball of a tool library whose radius is at most
  the fillet radius (a larger ball cannot reach into the fillet); ``None`` when the
  library has none.
* ``plan_fillet``: the pencil passes of ``fillet_paths.fillet_passes`` of every
  passage, each through the same M3 procedure as the junction paths
  (``plan.finish_path``: postures, reverse movements removed, interference remedy
  and repair), with the fillet tool. The result is a ``FinishResult`` of its own
  (its tool differs from the blade and hub finishing tool): one more APT file,
  ``finish_fillet.apt``.
* The passes round the blade edges are ``cam.finishing.edge_plan.plan_edges``.
* A pass whose first or last postures still break a rule after the remedy and the
  repair (round a cut trailing edge, where the pass turns from the side onto the
  edge face) is shortened at that end, to start after / end before them (at most
  ``TRIM_ROUNDS`` times, never below half its points), like the open-ended hub
  passes; postures still breaking one inside it are left out and the pass is cut
  into the runs between them, and the clean runs of what the trimming cut off its
  ends are finished as pieces of their own (``finish_pieces``): ``trimmed_points``
  in finish.json, and every point left out by pass, index, ball centre and blade u
  in finish.json's ``cut_short`` (``cut_short_entry``); what it leaves shows in the
  verification.
* ``neck_lean``: how far the fillet passes' axis leans off the blade so that the
  neck keeps the shank clearance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.collision import CollisionScene
from cam.finishing.fillet_paths import LEAN_DEG, fillet_passes
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, rotate_path, subset_path
from cam.finishing.plan import FinishResult, PathResult, finish_path
from cam.tools import DEFAULT_LIBRARY, Tool, load_tool_library
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.errors import InputError
from postproc.kinematics import Kinematics

__all__ = ["check_fillet_tool", "choose_fillet_tool", "cut_short_entry", "finish_pieces",
           "finish_runs", "finish_trimmed", "neck_lean", "plan_fillet"]

#: A ball this much larger than the fillet still counts as "equal" (rounding), mm.
RADIUS_SLACK = 1e-6
#: A pass is shortened at its ends at most this many times.
TRIM_ROUNDS = 3
#: Fewest points of a piece of a pass cut at postures breaking a rule.
MIN_PIECE = 2
#: The neck's clearance from the blade is planned this much beyond the required one, mm.
NECK_MARGIN = 0.5
#: Largest initial lean of the fillet passes' axis from the blade, deg: where a blade
#: leans over the hub, a larger lean brings the neck onto the hub (nine_blade's suction
#: side near the trailing edge: 35 deg touched it at the main job's 2.5 mm clearance).
MAX_LEAN_DEG = 30.0


def choose_fillet_tool(fillet_radius: float, library: str | Path | None = None
                       ) -> Tool | None:
    """The largest ball-end mill of ``library`` with radius at most ``fillet_radius``.

    Parameters
    ----------
    fillet_radius : float
        Fillet radius r_f, mm.
    library : str or Path, optional
        Tool library TOML (default: the bundled library).

    Returns
    -------
    Tool or None
        ``None`` when the design has no fillet or no ball fits; ties: the first in
        the library.
    """
    if fillet_radius <= 0:
        return None
    tools = load_tool_library(Path(library or DEFAULT_LIBRARY)).values()
    fits = [t for t in tools if t.shape == "ball" and t.radius <= fillet_radius + RADIUS_SLACK]
    if not fits:
        return None
    best = max(t.radius for t in fits)
    return next(t for t in fits if t.radius == best)


def check_fillet_tool(tool: Tool, fillet_radius: float) -> None:
    """``InputError`` unless ``tool`` is a ball that fits a fillet of ``fillet_radius`` mm."""
    if fillet_radius <= 0:
        raise InputError("the design has no blade-to-hub fillet to finish",
                         field="fillet_tool", value=tool.name,
                         accepted="no fillet tool, or a design with blade.fillet_radius_mm > 0")
    if tool.shape != "ball":
        raise InputError("fillet finishing needs a ball-end mill", field="fillet_tool",
                         value=tool.name, accepted="a tool of type 'ball'")
    if tool.radius > fillet_radius + RADIUS_SLACK:
        raise InputError(f"the fillet tool's ball (radius {tool.radius:g} mm) is larger "
                         f"than the fillet (radius {fillet_radius:g} mm)",
                         field="fillet_tool", value=tool.name,
                         accepted=f"a ball of diameter <= {2.0 * fillet_radius:g} mm")


def neck_lean(tool: Tool, clearance: float) -> float:
    """Initial lean of the fillet passes' axis away from the blade, rad.

    The neck starts ``h = flute_length - r`` above the ball centre, which lies about r
    from the blade; leaning the axis by ``a`` from the blade's ruling moves that
    point ``h sin(a)`` further off, so ``sin(a) = (clearance + NECK_MARGIN) / h``
    keeps the neck ``clearance`` from the blade wherever the blade is locally flat
    (a tapered neck widens more slowly than the lean moves it away for the library's
    tools). At least ``fillet_paths.LEAN_DEG``, at most ``MAX_LEAN_DEG``. With a 5 deg
    lean the nine_blade main job (ball4_taper, clearance 2.5 mm) left the neck 0.6-0.9
    mm from the blade at both ends of every pass; C turns cannot move the neck off a
    cut trailing edge's face, and the suction-side passes were shortened by up to 31
    points there, leaving the fillet round that edge unfinished (up to 2.2 mm).

    Parameters
    ----------
    tool : Tool
        The fillet ball-end mill.
    clearance : float
        Required shank and holder clearance, mm (``FinishOptions.clearance_mm``).
    """
    reach = tool.flute_length - tool.radius
    lowest = math.radians(LEAN_DEG)
    if reach <= 0:
        return math.radians(MAX_LEAN_DEG)
    wanted = math.asin(min((clearance + NECK_MARGIN) / reach, 1.0))
    return float(min(max(wanted, lowest), math.radians(MAX_LEAN_DEG)))


def _offenders(result: PathResult) -> NDArray[np.intp]:
    """Postures of a finished path that still interfere or break a rule."""
    return np.union1d(result.interference.interfering_points, result.rule_points)


def _trimmed(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
             options: FinishOptions, surfaces: ImpellerSurfaces
             ) -> tuple[PathResult, NDArray[np.intp], NDArray[np.intp]]:
    """``finish_trimmed``, the indices (into ``path``) of the points it kept and the
    offending postures of the whole pass's plan."""
    result = finish_path(path, tool, kins, scene, options, surfaces)
    whole = _offenders(result)
    length = len(path)
    kept = np.arange(length, dtype=np.intp)
    for _ in range(TRIM_ROUNDS):
        bad = _offenders(result)
        if not bad.size:
            break
        size = len(result.path)
        head, tail = bad[bad < size // 2], bad[bad >= size // 2]
        first = int(head.max()) + 1 if head.size else 0
        last = int(tail.min()) if tail.size else size
        if last - first < max(2, (length + 1) // 2):
            break
        keep = np.arange(first, last, dtype=np.intp)
        kept = kept[keep]
        result = finish_path(subset_path(result.path, keep), tool, kins, scene, options,
                             surfaces)
    result.trimmed = length - len(result.path)
    return result, kept, whole


def finish_trimmed(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                   options: FinishOptions, surfaces: ImpellerSurfaces) -> PathResult:
    """``finish_path``, then shortened at either end where postures break a rule.

    Offending postures in the first half move the start past the last of them, those
    in the second half the end before the first of them; finished again (at most
    ``TRIM_ROUNDS`` times, while at least half the points remain). ``trimmed`` is
    the number of points cut.
    """
    return _trimmed(path, tool, kins, scene, options, surfaces)[0]


def _runs(good: NDArray[np.bool_]) -> list[NDArray[np.intp]]:
    """Index runs of consecutive True entries with at least ``MIN_PIECE`` points."""
    edges = np.flatnonzero(np.diff(np.r_[False, good, False].astype(np.int8)))
    return [np.arange(a, b, dtype=np.intp) for a, b in zip(edges[::2], edges[1::2], strict=True)
            if b - a >= MIN_PIECE]


def _recovered(path: CutterPath, index: NDArray[np.intp], tool: Tool, kins: Kinematics,
               scene: CollisionScene, options: FinishOptions, surfaces: ImpellerSurfaces,
               accept: Callable[[PathResult], bool] | None
               ) -> list[tuple[NDArray[np.intp], PathResult]]:
    """Clean pieces of the points ``index`` (a run of postures the whole pass's plan
    found clean, which the pass's trimming cut off with an end).

    The run is finished on its own; where postures still break a rule it is cut
    there once more and the runs between are finished again. Only pieces that keep
    every rule (and that ``accept``, when given) are returned, with their indices into
    ``path``: a recovered piece adds cut, never an offence.
    """
    def clean(piece: PathResult) -> bool:
        return not _offenders(piece).size and (accept is None or accept(piece))

    if len(index) < MIN_PIECE:
        return []
    result = finish_path(subset_path(path, index), tool, kins, scene, options, surfaces)
    bad = _offenders(result)
    if not bad.size:
        return [(index, result)] if clean(result) else []
    good = np.ones(len(index), dtype=bool)
    good[bad] = False
    out = []
    for run in _runs(good):
        piece = finish_path(subset_path(path, index[run]), tool, kins, scene, options,
                            surfaces)
        if clean(piece):
            out.append((index[run], piece))
    return out


def finish_runs(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                options: FinishOptions, surfaces: ImpellerSurfaces,
                accept: Callable[[PathResult], bool] | None = None
                ) -> tuple[list[PathResult], NDArray[np.intp]]:
    """``finish_pieces`` and the indices (into ``path``) of the points left out, sorted.

    ``accept``: a further test a piece recovered from a trimmed end must pass (the
    edge passes' least lean off the surface, ``edge_plan``).
    """
    result, kept, whole = _trimmed(path, tool, kins, scene, options, surfaces)
    pieces = [(kept, result)]
    bad = _offenders(result)
    if bad.size:
        good = np.ones(len(result.path), dtype=bool)
        good[bad] = False
        runs = _runs(good)
        if runs:
            pieces = [(kept[run], finish_path(subset_path(result.path, run), tool, kins,
                                              scene, options, surfaces)) for run in runs]
    # the clean runs (in the whole pass's plan) of each end the trimming cut off
    clean = np.ones(len(path), dtype=bool)
    clean[whole] = False
    ends: list[list[tuple[NDArray[np.intp], PathResult]]] = [[], []]
    for side, cut in enumerate((np.arange(0, int(kept[0]), dtype=np.intp),
                                np.arange(int(kept[-1]) + 1, len(path), dtype=np.intp))):
        for run in _runs(clean[cut]):
            ends[side] += _recovered(path, cut[run], tool, kins, scene, options, surfaces,
                                     accept)
    pieces = ends[0] + pieces + ends[1]
    covered = np.concatenate([index for index, _ in pieces])
    lost = np.setdiff1d(np.arange(len(path), dtype=np.intp), covered)
    results = [piece for _, piece in pieces]
    if len(results) > 1:
        results = [_renamed(piece, f"{path.name}.{k + 1}") for k, piece in enumerate(results)]
    for piece in results:
        piece.trimmed = 0
    results[0].trimmed = len(path) - sum(len(piece.path) for piece in results)
    return results, lost


def _renamed(result: PathResult, name: str) -> PathResult:
    """``result`` with its path renamed ``name`` (a piece of a pass)."""
    result.path = replace(result.path, name=name)
    return result


def finish_pieces(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                  options: FinishOptions, surfaces: ImpellerSurfaces) -> list[PathResult]:
    """``finish_trimmed``; postures still breaking a rule inside the pass are left out,
    and the clean runs of the points the trimming cut off either end are kept.

    The pass is cut at the offending postures into the runs between (each of at least
    ``MIN_PIECE`` points, named ``<name>.<k>``), each finished again; the points left
    out count as ``trimmed`` (on the first piece). On nine_blade the fillet pass
    touching the blade contact round the suction side's cut trailing-edge corner ran
    0.34 mm into the built solid's fillet there at 4 of its 11 postures (the ball lies
    inside the rolling ball of the closed-form fillet, which the solid's interpolated
    fillet face leaves by that much at the corner): no tilt frees a ball that cuts the
    part.

    The trimming cuts a whole end up to its last offending posture; the clean postures
    before it are finished again as pieces of their own (``_recovered``). On the
    splitter fixture the suction-side fillet passes round the splitter's leading edge
    (ball4_taper, 2.5 mm shank clearance) break the clearance at postures 2-3 of 8
    only (the shank's foot, 10 mm up the axis, 2.03-2.24 mm from the splitter's own
    leading edge); trimming kept postures 5-7 and left up to 0.58 mm on the fillet
    there (507 of 37,500 fillet samples over the 0.4 mm scallop); with postures 0-1
    kept as well the passage's passes leave at most 0.36 mm (p99 0.24 mm) on that
    fillet, none over the scallop.
    """
    return finish_runs(path, tool, kins, scene, options, surfaces)[0]


def plan_fillet(surfaces: ImpellerSurfaces, tool: Tool, main_radius: float, kins: Kinematics,
                scene: CollisionScene, options: FinishOptions, *, scene_source: str,
                progress: Callable[[int, int, str], None] | None = None) -> FinishResult:
    """Finish the fillet pencil passes of every passage with ``tool``.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        Ball-end mill of radius at most the fillet radius (``check_fillet_tool``).
    main_radius : float
        Ball radius of the blade and hub finishing, mm (how far beyond the fillet the
        passes go, ``fillet_paths``).
    kins, scene, options, scene_source, progress
        As ``plan.plan_finishing`` (the same options: scallop, spacing, rules).

    Returns
    -------
    FinishResult
        Paths of operation ``"fillet"`` in passage order.
    """
    check_fillet_tool(tool, float(surfaces.spec.fillet_radius))
    base = fillet_passes(surfaces, tool.radius, main_radius, options.scallop_mm,
                         options.point_spacing_mm,
                         lean=neck_lean(tool, options.clearance_mm))
    return _finish_all(base, surfaces, tool, kins, scene, options, scene_source, progress)


def _finish_all(base: list[CutterPath], surfaces: ImpellerSurfaces, tool: Tool,
                kins: Kinematics, scene: CollisionScene, options: FinishOptions,
                scene_source: str, progress: Callable[[int, int, str], None] | None
                ) -> FinishResult:
    """Every passage's rotation of ``base``, each path finished (``finish_trimmed``)."""
    blades = surfaces.spec.blades
    count = blades if options.passages is None else min(options.passages, blades)
    ordered: list[CutterPath] = []
    for k in range(count):
        ordered += [p if k == 0 else rotate_path(p, k, surfaces.spec.pitch) for p in base]
    results: list[PathResult] = []
    cut_short = []
    for i, path in enumerate(ordered):
        pieces, lost = finish_runs(path, tool, kins, scene, options, surfaces)
        results += pieces
        if lost.size:
            cut_short.append(cut_short_entry(path, lost))
        if progress is not None:
            progress(i + 1, len(ordered), path.name)
    return FinishResult(results, tool, options, scene_source, extra={"cut_short": cut_short})


def cut_short_entry(path: CutterPath, lost: NDArray[np.intp]) -> dict[str, Any]:
    """finish.json's record of the points of a pass that were left out (``cut_short``):
    the pass, their indices in it, their ball centres (mm) and blade parameter u."""
    return {"path": path.name, "operation": path.operation, "points": len(path),
            "left_out": lost.tolist(),
            "centres_mm": np.round(path.centre[lost], 3).tolist(),
            "curve_u": np.round(path.curve_u[lost], 4).tolist()}
