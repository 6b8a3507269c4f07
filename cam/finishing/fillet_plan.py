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
  into the runs between them (``finish_pieces``): ``trimmed_points`` in
  finish.json; what it leaves shows in the verification.
* ``neck_lean``: how far the fillet passes' axis leans off the blade so that the
  neck keeps the shank clearance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from cam.collision import CollisionScene
from cam.finishing.fillet_paths import LEAN_DEG, fillet_passes
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, rotate_path, subset_path
from cam.finishing.plan import FinishResult, PathResult, finish_path
from cam.tools import DEFAULT_LIBRARY, Tool, load_tool_library
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.errors import InputError
from postproc.kinematics import Kinematics

__all__ = ["check_fillet_tool", "choose_fillet_tool", "finish_pieces", "finish_trimmed",
           "neck_lean",
           "plan_fillet"]

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


def finish_trimmed(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                   options: FinishOptions, surfaces: ImpellerSurfaces) -> PathResult:
    """``finish_path``, then shortened at either end where postures break a rule.

    Offending postures in the first half move the start past the last of them, those
    in the second half the end before the first of them; finished again (at most
    ``TRIM_ROUNDS`` times, while at least half the points remain). ``trimmed`` is
    the number of points cut.
    """
    result = finish_path(path, tool, kins, scene, options, surfaces)
    length = len(path)
    for _ in range(TRIM_ROUNDS):
        bad = np.union1d(result.interference.interfering_points, result.rule_points)
        if not bad.size:
            break
        size = len(result.path)
        head, tail = bad[bad < size // 2], bad[bad >= size // 2]
        first = int(head.max()) + 1 if head.size else 0
        last = int(tail.min()) if tail.size else size
        if last - first < max(2, (length + 1) // 2):
            break
        keep = np.arange(first, last, dtype=np.intp)
        result = finish_path(subset_path(result.path, keep), tool, kins, scene, options,
                             surfaces)
    result.trimmed = length - len(result.path)
    return result


def finish_pieces(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                  options: FinishOptions, surfaces: ImpellerSurfaces) -> list[PathResult]:
    """``finish_trimmed``; postures still breaking a rule inside the pass are left out.

    The pass is cut at them into the runs between (each of at least ``MIN_PIECE``
    points, named ``<name>.<k>``), each finished again; the points left out count as
    ``trimmed`` (on the first piece). On nine_blade the fillet pass touching the blade
    contact round the suction side's cut trailing-edge corner ran 0.34 mm into the
    built solid's fillet there at 4 of its 11 postures (the ball lies inside the
    rolling ball of the closed-form fillet, which the solid's interpolated fillet face
    leaves by that much at the corner): no tilt frees a ball that cuts the part.
    """
    result = finish_trimmed(path, tool, kins, scene, options, surfaces)
    bad = np.union1d(result.interference.interfering_points, result.rule_points)
    if not bad.size:
        return [result]
    good = np.ones(len(result.path), dtype=bool)
    good[bad] = False
    edges = np.flatnonzero(np.diff(np.r_[False, good, False].astype(np.int8)))
    runs = [np.arange(a, b, dtype=np.intp) for a, b in zip(edges[::2], edges[1::2], strict=True)
            if b - a >= MIN_PIECE]
    if not runs:
        return [result]
    pieces = [finish_path(replace(subset_path(result.path, run), name=f"{path.name}.{k + 1}"),
                          tool, kins, scene, options, surfaces) for k, run in enumerate(runs)]
    pieces[0].trimmed = len(path) - sum(len(piece.path) for piece in pieces)
    return pieces


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
    for i, path in enumerate(ordered):
        results += finish_pieces(path, tool, kins, scene, options, surfaces)
        if progress is not None:
            progress(i + 1, len(ordered), path.name)
    return FinishResult(results, tool, options, scene_source)
