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
  ``pieces.TRIM_ROUNDS`` times, never below half its points), like the open-ended
  hub passes; postures still breaking one inside it are left out and the pass is cut
  into the runs between them, and the clean runs of what the trimming cut off its
  ends are finished as pieces of their own (``pieces.finish_runs``, shared with the
  other operations): ``trimmed_points`` in finish.json, and every point left out by
  pass, index, ball centre and blade u in finish.json's ``cut_short``
  (``pieces.cut_short_entry``); what it leaves shows in the verification.
* ``neck_lean``: how far the fillet passes' axis leans off the blade so that the
  neck keeps the shank clearance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from cam.collision import CollisionScene
from cam.finishing.fillet_paths import LEAN_DEG, fillet_passes
from cam.finishing.options import FinishOptions
from cam.finishing.pass_groups import finish_ordered
from cam.finishing.paths import CutterPath, rotate_path
from cam.finishing.pieces import (
    cut_short_entry,
    finish_pieces,
    finish_runs,
    finish_trimmed,
)
from cam.finishing.plan import FinishResult
from cam.finishing.plan_memo import PlanMemo
from cam.tools import DEFAULT_LIBRARY, Tool, load_tool_library
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.errors import InputError
from postproc.kinematics import Kinematics

__all__ = ["check_fillet_tool", "choose_fillet_tool", "cut_short_entry", "finish_pieces",
           "finish_runs", "finish_trimmed", "neck_lean", "plan_fillet"]

#: A ball this much larger than the fillet still counts as "equal" (rounding), mm.
RADIUS_SLACK = 1e-6
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


def plan_fillet(surfaces: ImpellerSurfaces, tool: Tool, main_radius: float, kins: Kinematics,
                scene: CollisionScene, options: FinishOptions, *, scene_source: str,
                progress: Callable[[int, int, str], None] | None = None,
                memo: PlanMemo | None = None) -> FinishResult:
    """Finish the fillet pencil passes of every passage with ``tool``.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        Ball-end mill of radius at most the fillet radius (``check_fillet_tool``).
    main_radius : float
        Ball radius of the blade and hub finishing, mm (how far beyond the fillet the
        passes go, ``fillet_paths``).
    kins, scene, options, scene_source, progress, memo
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
    return _finish_all(base, surfaces, tool, kins, scene, options, scene_source, progress,
                       memo)


def _finish_all(base: list[CutterPath], surfaces: ImpellerSurfaces, tool: Tool,
                kins: Kinematics, scene: CollisionScene, options: FinishOptions,
                scene_source: str, progress: Callable[[int, int, str], None] | None,
                memo: PlanMemo | None = None) -> FinishResult:
    """Every passage's rotation of ``base``, each path finished (``finish_runs``).

    As ``plan.plan_finishing``: the same pass in the previous passage hands on its
    eq. 7 remedy step (``interference.StepHint``), tried first and proven before it
    is taken, so the results are those without it, with fewer checks.
    """
    blades = surfaces.spec.blades
    count = blades if options.passages is None else min(options.passages, blades)
    ordered: list[CutterPath] = []
    for k in range(count):
        ordered += [p if k == 0 else rotate_path(p, k, surfaces.spec.pitch) for p in base]
    results, cut_short = finish_ordered(ordered, tool, kins, scene, options, surfaces,
                                        memo, progress)
    return FinishResult(results, tool, options, scene_source, extra={"cut_short": cut_short})
