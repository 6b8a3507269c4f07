"""Posture repair where the paper's remedy cannot help (after M3 steps 6-7).

The paper's remedy (eq. 7) turns the whole path about the C axis. Where the tool
axis is almost parallel to the C axis (the outlet of a centrifugal impeller: hub
nearly flat, blade nearly upright) turning C hardly moves the tool, so a neck that
is too close to the blade tip stays there. Before giving up ("use a smaller tool",
step 8) the postures that still break a rule are repaired one by one:

1. **Rules** per posture: no tool part touches the part, shank and holder keep
   ``clearance_mm`` (also along the motion to the neighbours), the axis is at least
   ``min_normal_angle_deg`` from the contact normal and, on hub-contact paths, lead
   and tilt stay within ``max_lead_deg`` / ``max_tilt_deg``.
2. **Cone search**: for each posture breaking a rule, candidate axes
   ``cos(theta) a + sin(theta) (cos(psi) e1 + sin(psi) e2)`` on rings
   ``theta = k * tilt_search_step_deg`` up to ``tilt_search_deg`` and
   ``tilt_directions`` directions psi (e1 away from the wall); rings beyond
   ``PREFERRED_TILT_DEG`` (10 deg) only for postures no direction repairs within it
   (a tall obstacle beside an axis almost parallel to C: the splitter's outlet ends
   needed 25-30 deg); candidates that break
   a geometric rule (normal angle, lead/tilt) are dropped; per posture and direction
   the smallest theta whose posture is collision-free with ``clearance_mm +
   repair_margin_mm`` is kept. The ball centre stays where it is (tip = centre - R
   axis). Along each cluster of neighbouring offenders the directions are chosen
   together (``_chain``): least total change ``|dA| + |dC| + theta`` in the machine's
   joints, penalising targets against the direction of A or C.
3. **Monotone absorption** (``absorb_monotone``): the chosen joints become anchors;
   the curve between anchors, and on ramps of at least ``repair_blend_mm`` of path
   before and after them, is the affine remap of the old curve in proportion to its
   own travel. With anchors monotone in the axis direction the new curve is monotone
   wherever the old one was: no reverse movement can appear (the smoothing of steps
   3-5 is not undone). The ramps are extended until the old curve lies behind
   (before) / beyond (after) the anchors.
4. Everything is checked again (postures, motions, rules); new offenders (the
   ramps) go through 2-3 in the next round, up to ``repair_rounds``; the best round
   (fewest reverse movements, then interferences, then rule breaks) is kept.
   Postures still breaking a rule are reported by index (``unresolved``).
5. The rounds run with the cone up to ``PREFERRED_TILT_DEG`` first; where postures
   stay unresolved they run again with the whole ``tilt_search_deg`` cone and the
   better result is kept (``repair_postures``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.finishing.interference import InterferenceResult, check_path
from cam.finishing.monotone_blend import absorb_monotone
from cam.finishing.options import FinishOptions
from cam.finishing.posture import angle_between, lead_tilt
from cam.finishing.reversals import count_reversals, direction, smooth_monotone
from cam.tools import Tool
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = [
    "PREFERRED_TILT_DEG",
    "PostureRules",
    "RepairResult",
    "absorb_monotone",
    "cone_axes",
    "repair_postures",
    "rule_violations",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]
#: Geometric rules are met with this slack, rad (the cone candidates already meet them).
_RULE_SLACK = 1e-9
#: Cone angle up to which every tilt direction is searched, deg. Beyond it (up to
#: ``tilt_search_deg``) the rings go on only for postures with no clear direction yet:
#: a posture repairable within it gets the same candidates whatever the wider limit.
PREFERRED_TILT_DEG = 10.0


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


@dataclass(frozen=True)
class PostureRules:
    """Where the rules of one path are evaluated.

    Attributes
    ----------
    centre : (n, 3) float64
        Ideal ball centres (kept by every repair), mm.
    normal, tangent, away : (n, 3) float64
        Contact normal, feed direction and wall normal (the first cone direction).
    hub_contact : bool
        Lead and tilt limits apply (junction and hub passes).
    """

    centre: Array
    normal: Array
    tangent: Array
    away: Array
    hub_contact: bool


def rule_violations(axis: Array, rules: PostureRules, options: FinishOptions,
                    index: NDArray[np.intp] | None = None) -> Mask:
    """Postures (rows of ``axis``) breaking the normal-angle or lead/tilt rule, ``(n,)``.

    ``index`` selects the rows of ``rules`` the axes belong to (default all).
    """
    sel = slice(None) if index is None else index
    normal, tangent = rules.normal[sel], rules.tangent[sel]
    bad = angle_between(axis, normal) < math.radians(options.min_normal_angle_deg) - _RULE_SLACK
    if rules.hub_contact:
        lead, tilt = lead_tilt(axis, normal, tangent)
        bad |= np.abs(lead) > math.radians(options.max_lead_deg) + _RULE_SLACK
        bad |= np.abs(tilt) > math.radians(options.max_tilt_deg) + _RULE_SLACK
    return np.asarray(bad)


def cone_axes(axis: Array, first: Array, theta: float, directions: int) -> Array:
    """Axes on the cone of half-angle ``theta`` around each axis, ``(n, directions, 3)``.

    Direction 0 is ``first`` made perpendicular to the axis (the wall normal: tilting
    away from the wall), then every ``2 pi / directions`` about the axis.
    """
    e1 = first - np.einsum("ij,ij->i", first, axis)[:, None] * axis
    norm = np.linalg.norm(e1, axis=1)
    spare = np.cross(axis, np.where(np.abs(axis[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    e1 = np.where(norm[:, None] > 1e-9, e1 / np.maximum(norm, 1e-300)[:, None], _unit(spare))
    e2 = np.cross(axis, e1)
    psi = 2.0 * math.pi * np.arange(directions) / directions
    ring = (np.cos(psi)[None, :, None] * e1[:, None, :]
            + np.sin(psi)[None, :, None] * e2[:, None, :])
    return _unit(math.cos(theta) * axis[:, None, :] + math.sin(theta) * ring)


def _joint_targets(kins: Kinematics, tip: Array, axis: Array, current: Array
                   ) -> tuple[Array, Array]:
    """Rotary joints of candidate postures closest to ``current`` and their change.

    Both inverse branches, C wound to the turn nearest the current C, inside the
    machine's tilt limits. Returns ``(m, 2)`` joints (A, C, rad) and ``(m,)`` change
    ``|dA| + |dC|`` (inf where no branch is inside the limits).
    """
    branches = kins.inverse_branches(tip, axis)  # (2, m, 5)
    lower, upper = kins.machine.limits()
    a = branches[:, :, 3]
    c = branches[:, :, 4]
    c = c + 2.0 * math.pi * np.round((current[None, :, 1] - c) / (2.0 * math.pi))
    cost = np.abs(a - current[None, :, 0]) + np.abs(c - current[None, :, 1])
    cost = np.where((a >= lower[3]) & (a <= upper[3]), cost, np.inf)
    pick = np.argmin(cost, axis=0)
    rows = np.arange(len(tip))
    return (np.column_stack([a[pick, rows], c[pick, rows]]), np.asarray(cost[pick, rows]))


def _clusters(index: NDArray[np.intp]) -> list[NDArray[np.intp]]:
    """Split increasing indices into runs of neighbours (gaps of at most one point)."""
    breaks = np.flatnonzero(np.diff(index) > 2) + 1
    return [np.asarray(c, dtype=np.intp) for c in np.split(np.arange(len(index)), breaks)]


#: Cost of a repaired target moving A or C against its direction from the previous
#: one of the same cluster (rad; the monotone blend cannot meet such a target).
_AGAINST_PENALTY = 10.0


def _chain(rotary: Array, cost: Array, sense: Array) -> NDArray[np.intp]:
    """Tilt direction per posture of a cluster: least total cost along the chain.

    Dynamic programming (Viterbi) over the postures in path order: a posture's cost
    is its joint change (inf where the direction does not repair it); a step between
    consecutive postures costs ``_AGAINST_PENALTY`` for each of A and C whose targets
    go against the axis' direction.

    Parameters
    ----------
    rotary : (m, k, 2) float64
        Target joints (A, C) per posture and direction, rad.
    cost : (m, k) float64
    sense : (2,) float64
        Directions (+1 / -1) of A and C along the path.

    Returns
    -------
    (m,) intp
        The chosen direction per posture.
    """
    m, k = cost.shape
    total = cost[0].copy()
    back = np.zeros((m, k), dtype=np.intp)
    for i in range(1, m):
        step = rotary[i][None, :, :] - rotary[i - 1][:, None, :]  # (from, to, 2)
        against = np.sum(sense[None, None, :] * step < 0, axis=2) * _AGAINST_PENALTY
        reach = total[:, None] + against  # (from, to)
        back[i] = np.argmin(reach, axis=0)
        total = reach[back[i], np.arange(k)] + cost[i]
    choice = np.zeros(m, dtype=np.intp)
    choice[-1] = int(np.argmin(total))
    for i in range(m - 1, 0, -1):
        choice[i - 1] = back[i, choice[i]]
    return choice


@dataclass
class _Rings:
    """Where a ring search (``_search``) stood after ``ring`` rings: per offender of
    ``index`` and tilt direction, the smallest clear ring's cone angle (inf: none
    yet), the rotary target (A, C) and its cost."""

    index: NDArray[np.intp]
    theta_min: Array
    rotary: Array
    cost: Array
    ring: int


def _search(scene: CollisionScene, tool: Tool, kins: Kinematics, axis: Array, joints: Array,
            rules: PostureRules, index: NDArray[np.intp], options: FinishOptions,
            resume: _Rings | None = None) -> tuple[Array, Mask, Array, _Rings]:
    """Cone postures that meet every rule at ``index``, chosen along clusters.

    For every posture and tilt direction psi the smallest ring theta whose posture
    meets every rule is found (rings searched outwards, only for the pairs still
    open; beyond ``PREFERRED_TILT_DEG`` only for postures with no usable direction
    yet). Along each cluster of neighbouring offenders the directions are chosen
    together (``_chain``): least total change ``|dA| + |dC| + theta`` (near the C
    axis a tiny tilt can need a large C turn: the machine's change counts), with a
    penalty for consecutive targets against the direction of A or C (the monotone
    blend could not meet them).

    ``resume``: the rings a search of the same offenders, postures and options, with
    a cone no wider than this one's, has searched (its ``_Rings``): this search goes on
    from the next ring, with what they found (the rings up to the preferred cone are
    searched alike whatever the cone's limit).

    Returns
    -------
    target : (m, 2) float64
        Rotary joints (A, C) of the chosen postures, rad (the old ones where none).
    found : (m,) bool
    theta : (m,) float64
        Cone angle of the chosen posture, rad (NaN where none).
    rings : _Rings
        Where the search stood after its last ring.
    """
    m = len(index)
    k = options.tilt_directions
    if not m:
        return (np.zeros((0, 2)), np.zeros(0, dtype=bool), np.zeros(0),
                _Rings(index, np.zeros((0, k)), np.zeros((0, k, 2)), np.zeros((0, k)), 0))
    step = math.radians(options.tilt_search_step_deg)
    rings = int(math.floor(options.tilt_search_deg / options.tilt_search_step_deg + 1e-9))
    need = options.clearance_mm + options.repair_margin_mm
    first = 1
    if resume is not None and np.array_equal(resume.index, index):
        theta_min, rotary, cost = resume.theta_min.copy(), resume.rotary.copy(), \
            resume.cost.copy()
        first = resume.ring + 1
    else:
        theta_min = np.full((m, k), np.inf)
        rotary = np.zeros((m, k, 2))
        cost = np.full((m, k), np.inf)
    current = joints[index][:, 3:5]
    for ring in range(first, rings + 1):
        open_pairs = ~np.isfinite(theta_min)
        theta = ring * step
        if theta > math.radians(PREFERRED_TILT_DEG) + 1e-12:
            # beyond the preferred cone only postures with no clear direction yet
            open_pairs &= ~np.isfinite(cost).any(axis=1, keepdims=True)
        if not open_pairs.any():
            break
        cand = cone_axes(axis[index], rules.away[index], theta, k)
        who, psi = np.nonzero(open_pairs)
        axes = cand[who, psi]
        ok = ~rule_violations(axes, rules, options, index[who])
        if not ok.any():
            continue
        who, psi, axes = who[ok], psi[ok], axes[ok]
        tips = rules.centre[index[who]] - tool.radius * axes
        report = scene.check_postures(tool, tips, axes,
                                      cutter_allowance=options.cutter_allowance_mm,
                                      # only compared with need: exact below it
                                      clearance_cap=need, clearance_limits=(need,))
        clear = np.asarray(report.clearance, dtype=np.float64)
        good = ~np.asarray(report.collides, dtype=bool) & ~(np.isfinite(clear) & (clear < need))
        if not good.any():
            continue
        who, psi = who[good], psi[good]
        joint, change = _joint_targets(kins, tips[good], axes[good], current[who])
        theta_min[who, psi] = theta
        rotary[who, psi] = joint
        cost[who, psi] = change + theta  # joint change plus the tilt itself
    searched = _Rings(index, theta_min.copy(), rotary.copy(), cost.copy(), max(rings, first - 1))
    target = current.copy()
    found = np.zeros(m, dtype=bool)
    theta_used = np.full(m, np.nan)
    sense = np.array([direction(joints[:, 3]), direction(joints[:, 4])])
    for members in _clusters(index):
        usable = np.isfinite(theta_min[members]) & np.isfinite(cost[members])
        live = members[usable.any(axis=1)]
        if not live.size:
            continue
        choice = _chain(rotary[live], np.where(usable[usable.any(axis=1)], cost[live], np.inf),
                        sense)
        target[live] = rotary[live, choice]
        theta_used[live] = theta_min[live, choice]
        found[live] = True
    return target, found, theta_used, searched


def _arc(centre: Array) -> Array:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centre, axis=0), axis=1))])



@dataclass
class RepairResult:
    """What ``repair_postures`` did to one path.

    Attributes
    ----------
    interference : InterferenceResult
        Final check of the repaired postures.
    joints : (n, 5) float64
        Joints of the final postures (inverse kinematics).
    rounds : int
        Search-and-absorb rounds made.
    tilted : (k,) intp
        Postures a cone search repaired (any round).
    max_tilt : float
        Largest cone angle used, rad.
    unresolved : (j,) intp
        Postures still breaking a rule (collision, clearance, normal angle, lead/tilt).
    """

    interference: InterferenceResult
    joints: Array
    rounds: int
    tilted: NDArray[np.intp]
    max_tilt: float
    unresolved: NDArray[np.intp]


def offenders(inter: InterferenceResult, rules: PostureRules,
              options: FinishOptions) -> NDArray[np.intp]:
    """Postures breaking a rule: collisions, clearance, both ends of a bad motion,
    normal angle, lead/tilt."""
    bad = inter.collides.copy()
    bad[:-1] |= inter.motion_collides
    bad[1:] |= inter.motion_collides
    bad |= rule_violations(inter.axis, rules, options)
    return np.asarray(np.flatnonzero(bad), dtype=np.intp)


def _settle(kins: Kinematics, joints: Array, centre: Array, radius: float, arc: Array,
            options: FinishOptions) -> Array:
    """Joints the post will compute for the postures of ``joints`` (ball centres kept).

    Next to the C axis the inverse kinematics may pick another branch or C winding
    than the blended curve and so bring back a reverse movement; then A and C are
    smoothed again (``smooth_monotone``, the options' scope) and recomputed, twice
    at most. The caller re-checks collisions and keeps the round only if it is better.
    """
    deadband = math.radians(options.reversal_deadband_deg)
    if len(arc) < 3:
        axis = _unit(kins.forward(joints)[1])
        return kins.inverse(centre - radius * axis, axis)
    step = np.maximum(np.diff(arc), 1e-9 * max(float(np.max(np.diff(arc))), 1.0))
    t = np.concatenate([[0.0], np.cumsum(step)])
    t /= t[-1]  # strictly increasing in [0, 1], as the smoothing of plan.py
    for attempt in range(3):
        axis = _unit(kins.forward(joints)[1])
        joints = kins.inverse(centre - radius * axis, axis)
        if attempt == 2:
            break
        smoothed = joints.copy()
        changed = False
        for col in (3, 4):
            if count_reversals(joints[:, col], deadband):
                smoothed[:, col] = smooth_monotone(
                    t, joints[:, col], basis_functions=options.basis_functions,
                    min_shift=math.radians(options.phi_l_deg), deadband=deadband,
                    max_rounds=options.max_smoothing_iterations,
                    scope=options.smoothing_scope).values
                changed = True
        if not changed:
            break
        joints = smoothed
    return joints


def _badness(inter: InterferenceResult, joints: Array, rules: PostureRules,
             options: FinishOptions) -> tuple[int, int, int]:
    """(A and C reverse movements, postures or motions interfering, postures breaking a
    geometric rule): smaller is better, in this order."""
    deadband = math.radians(options.reversal_deadband_deg)
    return (count_reversals(joints[:, 3], deadband) + count_reversals(joints[:, 4], deadband),
            int(inter.collides.sum() + inter.motion_collides.sum()),
            int(rule_violations(inter.axis, rules, options).sum()))


def repair_postures(scene: CollisionScene, tool: Tool, kins: Kinematics, rules: PostureRules,
                    inter: InterferenceResult, joints: Array, options: FinishOptions
                    ) -> RepairResult:
    """Repair the postures that break a rule (module docstring), rounds until none.

    The rounds run first with the cone up to ``PREFERRED_TILT_DEG``; only when
    postures stay unresolved and ``tilt_search_deg`` is wider do they run again from
    the same start with the wider cone, and the better of the two results is kept
    (fewest reverse movements, then interferences, then rule breaks; the first on a
    tie). So a path the narrow cone repairs gets exactly what it got before the wider
    search existed, and no path ends worse than with the narrow cone alone.

    Parameters
    ----------
    inter : InterferenceResult
        The path after the eq. 7 remedy (postures and their check).
    joints : (n, 5) float64
        Their joints (X Y Z mm, A C rad), reverse-movement free.
    """
    narrow = replace(options, tilt_search_deg=min(options.tilt_search_deg,
                                                  PREFERRED_TILT_DEG))
    first, searched = _repair_rounds(scene, tool, kins, rules, inter, joints, narrow)
    if not first.unresolved.size or options.tilt_search_deg <= PREFERRED_TILT_DEG:
        return first
    # the wide run's first round starts where the narrow one's did: its rings up to
    # the preferred cone are the ones the narrow search has checked
    wide, _ = _repair_rounds(scene, tool, kins, rules, inter, joints, options, searched)
    if _badness(wide.interference, wide.joints, rules, options) < \
            _badness(first.interference, first.joints, rules, options):
        return wide
    return first


def _repair_rounds(scene: CollisionScene, tool: Tool, kins: Kinematics, rules: PostureRules,
                   inter: InterferenceResult, joints: Array, options: FinishOptions,
                   resume: _Rings | None = None) -> tuple[RepairResult, _Rings | None]:
    """Search-and-absorb rounds with the options' cone (``repair_postures``); also
    where the first round's search stood (``_search``'s ``resume`` for its first
    round: ``None`` without a round)."""
    radius = tool.radius
    arc = _arc(rules.centre)
    deadband = math.radians(options.reversal_deadband_deg)
    tilted: set[int] = set()
    max_tilt = 0.0
    rounds = 0
    bad = offenders(inter, rules, options)
    best = (_badness(inter, joints, rules, options), inter, joints, bad, set(tilted), max_tilt)
    first_search: _Rings | None = None
    while bad.size and rounds < options.repair_rounds:
        rounds += 1
        target, found, theta, searched = _search(scene, tool, kins, inter.axis, joints,
                                                 rules, bad, options,
                                                 resume if rounds == 1 else None)
        first_search = searched if rounds == 1 else first_search
        if not found.any():
            break
        index = bad[found]
        new = joints.copy()
        for col in (3, 4):
            wanted = target[found, col - 3]
            if np.allclose(wanted, joints[index, col], atol=deadband, rtol=0):
                continue
            new[:, col] = absorb_monotone(joints[:, col], index, wanted, arc,
                                          options.repair_blend_mm, deadband)
        joints = _settle(kins, new, rules.centre, radius, arc, options)
        axis = _unit(kins.forward(joints)[1])
        tip = rules.centre - radius * axis
        inter_new = check_path(scene, tool, tip, axis, options)
        inter_new.delta_c, inter_new.steps, inter_new.c_max = (inter.delta_c, inter.steps,
                                                               inter.c_max)
        inter = inter_new
        tilted.update(int(i) for i in index)
        max_tilt = max(max_tilt, float(np.nanmax(theta)))
        bad = offenders(inter, rules, options)
        badness = _badness(inter, joints, rules, options)
        if badness < best[0]:
            best = (badness, inter, joints, bad, set(tilted), max_tilt)
    _, inter, joints, bad, tilted, max_tilt = best
    return RepairResult(inter, joints, rounds, np.asarray(sorted(tilted), dtype=np.intp),
                        max_tilt, bad), first_search
