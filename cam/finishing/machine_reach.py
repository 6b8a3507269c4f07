"""Can the finishing postures fit the machine at all? A cheap check before planning.

Planning around the machine model (``cam.finishing.machine_obstacle``) handles a
posture too close to the machine like any collision: the eq. 7 remedy turns C in
``delta_c_deg`` steps up to Cmax, the posture repair searches a cone of
``tilt_search_deg``. Where no posture the planner may choose keeps the machine clear
(a short tool at A -96 deg on a small part: the 500 mm head meets the platter)
every step of that machinery fails posture after posture, for minutes, before the
postures are named. ``check_machine_reach`` asks the machine model alone, before
any per-point planning, whether each path's starting postures (the planner's own:
initial axes, normal-angle lean, reversals removed) or some posture the remedy and
the repair may reach from them keeps every machine pair its clearance plus the
obstacle's margin:

* the starting postures of every path of every passage, in one batched query;
* for those that do not clear: candidates turned about C by ``0, Cmax / 2, Cmax``
  (the remedy's range) and tilted on cones of ``tilt_search_deg / 2`` and
  ``tilt_search_deg`` (and half and all of the repair's preferred 10 deg, when
  smaller) in ``tilt_directions`` directions (the repair's), the ball
  centre kept; a posture is unreachable when none of them clears.

The candidates ignore the part and the posture rules (a superset of what planning
may pick, so a posture reported here is one planning would not clear either, up to
the candidates' spacing). The points of an open-ended pass past its middle are not
counted (planning may trim them off).

When some are unreachable the finish stage stops (``InputError``, exit 2) with the
operation, the paths and passages, the A range, the closest pair and what would fix
it, computed with the same query: the shortest gauge length (tool tip to the
holder's gauge line) with which every such posture has a clearing candidate, and how
much higher the part would have to stand on its riser (``remedies``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.options import FinishOptions
from cam.finishing.plan import _inverse, remove_reversals
from cam.finishing.posture import c_max, enforce_normal_angle, initial_axes, rotate_about_z
from cam.finishing.repair import PREFERRED_TILT_DEG, cone_axes
from cam.verify.machine_query import MachineClearance
from cam.verify.machine_scene import MachineScene, machine_scene
from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from cam.finishing.machine_obstacle import MachineObstacle
    from cam.finishing.paths import CutterPath
    from cam.tools import Tool
    from postproc.machine_model import Solid

__all__ = ["Reach", "check_machine_reach", "reach_of", "remedies"]

Array = NDArray[np.float64]
#: Turns about C tried, as fractions of the path's Cmax (the eq. 7 remedy's range).
C_TURNS = (0.0, 0.5, 1.0)
#: Cone half-angles tried, as fractions of ``tilt_search_deg`` (the repair's cone) and of
#: the repair's preferred cone (``repair.PREFERRED_TILT_DEG``, when smaller).
CONE_RINGS = (0.5, 1.0)
#: Unreachable postures a remedy is searched on at most (spread over all of them).
REMEDY_POINTS = 150
#: Longest extra gauge length / riser height searched, mm.
REMEDY_LIMIT = 400.0
#: Resolution of the remedies, mm.
REMEDY_STEP = 1.0


@dataclass
class Reach:
    """What the machine model leaves reachable of a set of finishing paths.

    Attributes
    ----------
    centre, axis : (m, 3) float64
        Ball centres (mm) and starting unit axes of the postures that do not clear the
        machine (W).
    turns : (m,) float64
        The path's Cmax of each, rad (the remedy's range).
    away : (m, 3) float64
        The wall normal of each (the repair cone's first direction).
    unreachable : (m,) bool
        No candidate posture clears the machine.
    best : (m,) float64
        Best margin (distance - clearance, mm) over the candidates.
    pair : list of (str, str)
        The pair holding ``best`` per posture.
    clearance : (m,) float64
        That pair's clearance, mm (``best + clearance`` is its distance).
    path, point : list of str, (m,) intp
        Path name and point index of each posture.
    operation : list of str
    tilt : (m,) float64
        A (the tilt joint) of the starting posture, deg (NaN: outside the limits).
    postures : int
        Postures checked in all.
    """

    centre: Array
    axis: Array
    turns: Array
    away: Array
    unreachable: NDArray[np.bool_]
    best: Array
    pair: list[tuple[str, str]]
    clearance: Array
    path: list[str]
    point: NDArray[np.intp]
    operation: list[str]
    tilt: Array
    postures: int


def starting_axes(path: CutterPath, tool: Tool, kins: Any, options: FinishOptions
                  ) -> tuple[Array, float]:
    """The planner's starting axes of a path (``plan._finish_once`` before the remedy)
    and the sense of its C turn."""
    axis0, sign = initial_axes(path.reference_axis, path.away,
                               math.radians(options.c_tilt_deg))
    axis0, _ = enforce_normal_angle(axis0, path.normal, path.tangent,
                                    math.radians(options.min_normal_angle_deg))
    joints0 = _inverse(kins, path.centre - tool.radius * axis0, axis0, path.name)
    axis, _, _ = remove_reversals(path.centre, axis0, joints0, kins, tool.radius, options,
                                  path.name)
    return axis, sign


def candidates(axis: Array, away: Array, turn: Array, options: FinishOptions) -> Array:
    """Candidate axes per posture ``(m, k, 3)``: C turns times cone rings (module doc)."""
    out = []
    widest = options.tilt_search_deg
    cones = sorted({ring * limit for ring in CONE_RINGS
                    for limit in (widest, min(widest, PREFERRED_TILT_DEG))})
    for fraction in C_TURNS:
        turned = axis if fraction == 0.0 else rotate_about_z(axis, fraction * turn)
        out.append(turned[:, None, :])
        for cone in cones:
            out.append(cone_axes(turned, away, math.radians(cone), options.tilt_directions))
    return np.concatenate(out, axis=1)


def best_margin(query: MachineClearance, radius: float, centre: Array, axes: Array,
                enough: float) -> tuple[Array, NDArray[np.intp]]:
    """Best margin over candidate axes ``(m, k, 3)`` per posture, mm, and its pair.

    Candidates are asked column by column, only for postures not yet at ``enough``.
    """
    m, k = axes.shape[:2]
    best = np.full(m, -math.inf)
    pair = np.zeros(m, dtype=np.intp)
    for column in range(k):
        rows = np.flatnonzero(best < enough)
        if not rows.size:
            break
        axis = axes[rows, column]
        margin, worst = query.postures_margin(centre[rows] - radius * axis, axis, cap=enough)
        better = margin > best[rows]
        best[rows[better]] = margin[better]
        pair[rows[better]] = worst[better]
    return best, pair


def reach_of(obstacle: MachineObstacle, tool: Tool, paths: Sequence[CutterPath],
             options: FinishOptions) -> Reach:
    """The machine reach of ``paths`` (every passage) with ``tool`` (module docstring).

    Paths of passages other than 0 reuse the starting axes of their passage-0 twin
    turned about C (the planner's smoothing works in joints, where a passage differs by
    its pitch in C only).
    """
    query = obstacle.query(tool)
    enough = obstacle.margin
    first: dict[str, tuple[Array, float, CutterPath]] = {}
    centre, axis, turns, away, names, points, ops = [], [], [], [], [], [], []
    postures = 0
    for path in paths:
        key = path.name.split(".", 1)[-1]
        if key not in first:
            start, sense = starting_axes(path, tool, obstacle.kins, options)
            first[key] = (start, sense, path)
        start, sense, twin = first[key]
        turn = math.atan2(float(path.centre[0, 1]), float(path.centre[0, 0])) - math.atan2(
            float(twin.centre[0, 1]), float(twin.centre[0, 0]))
        here = rotate_about_z(start, turn) if path is not twin else start
        postures += len(path)
        margin, _ = query.postures_margin(path.centre - tool.radius * here, here, cap=enough)
        bad = np.flatnonzero(margin < enough)
        if path.open_end:
            bad = bad[bad < max(2, (len(path) + 1) // 2)]
        if not bad.size:
            continue
        limit = float(np.min(c_max(path.centre, path.reference_axis, path.opposite_tip)))
        centre.append(path.centre[bad])
        axis.append(here[bad])
        turns.append(np.full(bad.size, sense * limit))
        away.append(path.away[bad])
        names += [path.name] * bad.size
        points.append(bad)
        ops += [path.operation] * bad.size
    if not centre:
        empty = np.zeros((0, 3))
        return Reach(empty, empty, np.zeros(0), empty, np.zeros(0, bool), np.zeros(0), [],
                     np.zeros(0), [], np.zeros(0, np.intp), [], np.zeros(0), postures)
    c, a, t, w = (np.concatenate(x) for x in (centre, axis, turns, away))
    best, pair = best_margin(query, tool.radius, c, candidates(a, w, t, options), enough)
    tilt = np.full(len(c), math.nan)
    lower, upper = obstacle.kins.machine.limits()
    for branch in obstacle.kins.inverse_branches(c - tool.radius * a, a):
        inside = (branch[:, 3] >= lower[3] - 1e-9) & (branch[:, 3] <= upper[3] + 1e-9)
        tilt = np.where(np.isnan(tilt) & inside, np.degrees(branch[:, 3]), tilt)
    return Reach(c, a, t, w, best < enough, best, [query.names[int(k)] for k in pair],
                 query.clearance[pair], names, np.concatenate(points), ops, tilt, postures)


def _longer(tool: Tool, extra: float) -> Tool:
    """``tool`` in a holder ``extra`` mm longer: the holder's nose segment stretched, the
    segments above it moved up (the stick-out and the cutter unchanged)."""
    if not tool.holder:
        return replace(tool, stickout=tool.stickout + extra)
    nose, *rest = tool.holder
    return replace(tool, holder=(replace(nose, z1=nose.z1 + extra),
                                 *(replace(s, z0=s.z0 + extra, z1=s.z1 + extra) for s in rest)))


def _shifted(solid: Solid, dz: float) -> Solid:
    """``solid`` moved by ``dz`` mm along z of its group frame."""
    move = np.array([0.0, 0.0, dz])
    return replace(solid, vertices=solid.vertices + move,
                   box=None if solid.box is None else (solid.box[0], solid.box[1] + move),
                   cylinder=None if solid.cylinder is None else (
                       *solid.cylinder[:3], solid.cylinder[3] + move),
                   pieces=tuple(p + move for p in solid.pieces))


def _raised(obstacle: MachineObstacle, height: float) -> tuple[Any, Any]:
    """Model and kinematics with the part ``height`` mm higher above the table: every
    table-side component and the tilt pivot ``height`` lower in W, the riser taller."""
    import copy

    from postproc.machine_model import TOOL_SIDE

    model = obstacle.model
    parts = tuple(s if s.group in TOOL_SIDE else _shifted(s, -height)
                  for s in model.components)
    fixture = model.fixture
    if fixture is not None:  # the riser (a chuck's body) under the part grows
        fixture = fixture.model_copy(update={"height": fixture.height + height})
    kins = copy.copy(obstacle.kins)
    kins.offset = np.asarray(obstacle.kins.offset, np.float64) - np.array([0.0, 0.0, height])
    return replace(model, components=parts, fixture=fixture), kins


def _smallest(fits: Callable[[float], bool]) -> float | None:
    """Smallest ``x`` in (0, REMEDY_LIMIT] with ``fits(x)`` (doubling, then bisection
    to ``REMEDY_STEP``), assuming monotone; ``None`` when even the limit does not fit."""
    low, high = 0.0, 8.0
    while not fits(high):
        low = high
        if high >= REMEDY_LIMIT:
            return None
        high = min(2.0 * high, REMEDY_LIMIT)
    while high - low > REMEDY_STEP:
        mid = 0.5 * (low + high)
        low, high = (low, mid) if fits(mid) else (mid, high)
    return math.ceil(high / REMEDY_STEP) * REMEDY_STEP


def remedies(obstacle: MachineObstacle, tool: Tool, reach: Reach, options: FinishOptions
             ) -> dict[str, float | None]:
    """Extra gauge length and extra riser height (mm) with which every unreachable
    posture of ``reach`` gets a clearing candidate (``None``: not within
    ``REMEDY_LIMIT``). Searched on up to ``REMEDY_POINTS`` of them, then confirmed on
    all (the search goes on if the confirmation fails). Postures whose closest pair is
    the cutter and shank themselves (``tool``) are left out, and so are the pairs of
    the cutter and shank: neither remedy moves them (``spindle_side``); the longer
    gauge length is a longer holder (the stick-out kept)."""
    rows = np.flatnonzero(reach.unreachable & spindle_side(reach))
    if not rows.size:
        return {"gauge_length_mm": None, "riser_mm": None}
    spread = rows[np.unique(np.linspace(0, rows.size - 1, min(rows.size, REMEDY_POINTS)
                                        ).round().astype(np.intp))]
    axes = candidates(reach.axis[rows], reach.away[rows], reach.turns[rows], options)
    index = {int(r): k for k, r in enumerate(rows)}
    some = np.array([index[int(r)] for r in spread], dtype=np.intp)

    def clears(query: MachineClearance, radius: float, subset: NDArray[np.intp]) -> bool:
        best, _ = best_margin(query, radius, reach.centre[rows][subset], axes[subset],
                              obstacle.margin)
        return bool((best >= obstacle.margin).all())

    def search(make: Callable[[float], MachineClearance], radius: float) -> float | None:
        cache: dict[float, MachineClearance] = {}

        def fits(x: float, subset: NDArray[np.intp] = some) -> bool:
            if x not in cache:
                cache[x] = make(x)
            return clears(cache[x], radius, subset)

        found = _smallest(fits)
        everyone = np.arange(len(rows), dtype=np.intp)
        while found is not None and not fits(found, everyone):
            def fits_all(x: float, below: float = found) -> bool:
                return x > below and fits(x, everyone)

            found = _smallest(fits_all)
        return found

    def spindle(scene: MachineScene, kins: Any) -> MachineClearance:
        pairs = [p for p in scene.pairs if "tool" not in
                 (scene.solids[p[0]].name, scene.solids[p[1]].name)]
        return MachineClearance(replace(scene, pairs=pairs), kins, tool_side=True)

    def longer(extra: float) -> MachineClearance:
        return spindle(machine_scene(obstacle.model, _longer(tool, extra), None,
                                     part=obstacle.part), obstacle.kins)

    def raised(height: float) -> MachineClearance:
        model, kins = _raised(obstacle, height)
        return spindle(machine_scene(model, tool, None, part=obstacle.part), kins)

    return {"gauge_length_mm": search(longer, tool.radius),
            "riser_mm": search(raised, tool.radius)}


def spindle_side(reach: Reach) -> NDArray[np.bool_]:
    """Postures whose closest pair is not the cutter and shank (``tool``): the spindle
    nose or head, the holder, ... - what a longer gauge length or a higher part moves
    away."""
    return np.array(["tool" not in pair for pair in reach.pair], dtype=bool)


def _ranges(values: Sequence[int]) -> str:
    """``0-3, 5``: sorted integers as ranges."""
    out: list[str] = []
    for v in sorted(set(values)):
        if out and out[-1].split("-")[-1] == str(v - 1):
            out[-1] = f"{out[-1].split('-')[0]}-{v}"
        else:
            out.append(str(v))
    return ", ".join(out)


def describe(reach: Reach, tool: Tool, fix: dict[str, float | None], limit: int = 4) -> str:
    """One message naming what is unreachable, the closest pairs and the remedies."""
    rows = np.flatnonzero(reach.unreachable)
    parts = []
    for op in dict.fromkeys(reach.operation[r] for r in rows):
        mine = [int(r) for r in rows if reach.operation[r] == op]
        kinds = sorted({reach.path[r].split(".", 1)[-1] for r in mine})
        passages = [int(reach.path[r].split(".", 1)[0].lstrip("p") or 0) for r in mine]
        tilt = reach.tilt[mine]
        tilt = tilt[np.isfinite(tilt)]
        pairs: dict[tuple[str, str], list[int]] = {}
        for r in mine:
            pairs.setdefault(reach.pair[r], []).append(r)
        closest = []
        for (a, b), which in sorted(pairs.items(), key=lambda item: -len(item[1])):
            worst = min(which, key=lambda r: reach.best[r])
            least = reach.best[worst] + reach.clearance[worst]
            closest.append(f"{a} - {b} at {len(which)} ({least:.2f} mm at best, "
                           f"clearance {reach.clearance[worst]:.2f} mm)")
        shown = ", ".join(kinds[:limit]) + (f" and {len(kinds) - limit} more"
                                            if len(kinds) > limit else "")
        span = f", A {tilt.min():.1f} to {tilt.max():.1f} deg" if tilt.size else ""
        parts.append(f"operation {op}: {len(mine)} postures of {shown} (passages "
                     f"{_ranges(passages)}){span}; closest: " + ", ".join(closest))
    text = ("finishing cannot keep the machine's components clear (no posture within the "
            "eq. 7 C turn and the repair's cone keeps every pair its clearance): "
            + "; ".join(parts) + ".")
    side = reach.unreachable & spindle_side(reach)
    if side.any():
        gauge, riser = fix.get("gauge_length_mm"), fix.get("riser_mm")
        remedy = [f"a longer holder: a gauge length of at least {tool.length + gauge:.0f} mm "
                  f"({tool.name}: {tool.length:.0f} mm, the same stick-out)"
                  if gauge is not None else
                  f"no gauge length up to {tool.length + REMEDY_LIMIT:.0f} mm",
                  f"the part {riser:.0f} mm higher on its riser (the tilt pivot offset "
                  "changes by as much)" if riser is not None else
                  f"no riser up to {REMEDY_LIMIT:.0f} mm higher"]
        text += (f" For the {int(side.sum())} postures where the spindle side meets the "
                 "machine, what would fit: " + ", or ".join(remedy) + ".")
    own = reach.unreachable & ~spindle_side(reach)
    if own.any():
        others = sorted({b if a == "tool" else a for a, b in
                         (reach.pair[int(r)] for r in np.flatnonzero(own))})
        text += (f" At {int(own.sum())} postures the cutter and shank themselves meet "
                 f"{', '.join(others)}: a longer tool or a higher part does not help there "
                 "(a smaller fixture, or no finishing there on this machine).")
    return text


def check_machine_reach(obstacle: MachineObstacle, tool: Tool, paths: Sequence[CutterPath],
                        options: FinishOptions, machine: str) -> Reach:
    """Raise ``InputError`` (exit 2) when some posture of ``paths`` cannot clear the
    machine (module docstring); else return the reach (what planning will repair).

    Parameters
    ----------
    machine : str
        The machine file (named in the error).
    """
    reach = reach_of(obstacle, tool, paths, options)
    if reach.unreachable.any():
        fix = remedies(obstacle, tool, reach, options)
        raise InputError(describe(reach, tool, fix), field="model", value=tool.name,
                         accepted="a tool, riser or machine with which every finishing "
                         "posture keeps the machine's clearances",
                         file=machine)
    return reach
