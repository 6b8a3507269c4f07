"""Joining finishing passes into one ``Toolpath`` per operation: short, checked links.

Every pass is left by a short **departure** and entered by a short **approach** (lead-in),
both at the cutting feed, and the tool moves between the two on the lowest link that
is collision-free as the machine will move:

1. **direct**: one rapid from the departure point to the approach point;
2. **clearance**: out along the tool axis to the clearance cylinder about the part
   axis (``Envelope``: the impeller's bounding cylinder plus ``retract_clearance_mm``),
   one rapid on it to above the next pass (the rotary axes turn during that move) and
   in along the next pass's axis;
3. **retract** (no checked link found): the rapids of the earlier scheme (retract to
   the cylinder, turn about the part axis in steps, in again) left unchecked, so the
   post retracts to the machine's safe Z around every rotary step; reported per link.

Rapids of kinds 1 and 2 are *checked links* (``Toolpath.link``): each is checked
where the machine will really move, along the straight line in joint space between
the two poses' joints from the machine's inverse kinematics (the branch and C
winding the post picks by continuity), with the cutter grown by ``clearance`` and
shank and holder kept ``clearance`` away (in the chain ``clearance_mm`` includes the
stock roughing left, so a rapid never enters the in-process stock); the post writes
each as one ``G0`` with no retract (docs/postprocessors.md): a half turn of C at
constant height is one move in the APT and the NC.

The departure starts at the pass's last posture and goes ``departure`` mm (or the
shortest of ``DEPARTURE_SCALES`` times it for which the grown cutter is clear) along
the tool axis, along the contact normal ``e`` away from the surfaces the ball
touches, or half-way between; it is a feed move checked like a cut. The approach
mirrors it at the next pass's first posture. Where no such point is clear (the
posture's own shank or holder collides) the departure is the shortest candidate whose
moves out, to it and then along the axis to the clearance cylinder, keep the cutter
out of the part as a cut does; where none does, the pass is left, as before, along its
axis out to the clearance cylinder at feed, unchecked.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.axial_moves import AxialMove, axial_moves
from cam.finishing.envelope import Envelope, retract_length, stepped_link
from cam.finishing.lead_blend import Lead, tangent_leads
from cam.finishing.link_rules import LinkRules, PassEnds
from cam.finishing.stepover_blend import Stepover, feed_stepover
from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.kinematics.base import OverTravelError
from postproc.pole import keeps_branch
from postproc.toolpath import Cutter, MoveKind, Toolpath

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from postproc.kinematics import Kinematics

__all__ = ["DEPARTURE_SCALES", "Envelope", "LinkRules", "Linker", "PassEnds", "retract_length"]

Array = NDArray[np.float64]
#: Departure and approach lengths tried, in units of ``LinkRules.departure``.
DEPARTURE_SCALES = (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)
#: Link kinds from the lowest; a link the post moves into the part goes one up.
_LEVELS = ("direct", "clearance", "retract")
#: Rounds of that check.
_ROUNDS = 4


@dataclass
class _Moves:
    """Poses appended to an operation (tip, axis, kind, feed, checked-link flag)."""

    tip: list[Array] = field(default_factory=list)
    axis: list[Array] = field(default_factory=list)
    kind: list[int] = field(default_factory=list)
    feed: list[float] = field(default_factory=list)
    link: list[bool] = field(default_factory=list)
    delta: dict[int, Array] = field(default_factory=dict)

    def add(self, tip: Array, axis: Array, kind: MoveKind, feed: float, link: bool,
            joints: Array | None = None) -> None:
        """Append poses; ``joints`` ((k + 1, 5): start and each pose) of checked links."""
        steps = None if joints is None else np.diff(joints, axis=0)
        for i, (t, a) in enumerate(zip(np.reshape(tip, (-1, 3)), np.reshape(axis, (-1, 3)),
                                       strict=True)):
            if link and steps is not None:
                self.delta[len(self.tip)] = steps[i]
            self.tip.append(t)
            self.axis.append(a)
            self.kind.append(int(kind))
            self.feed.append(feed)
            self.link.append(link)


def _unit(v: Array) -> Array:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


class Linker:
    """Builds one operation's linked toolpath and reports every link."""

    def __init__(self, scene: CollisionScene, kins: Kinematics, rules: LinkRules) -> None:
        self.scene = scene
        self.kins = kins
        self.rules = rules
        #: ``rapid_free``'s answers by the joints' bytes: ``join`` builds the operation
        #: again after raising a link, and links it keeps are asked again (same scene,
        #: rules and joints: the same answer)
        self._rapids: dict[bytes, bool] = {}

    # -- checks ---------------------------------------------------------------------

    def rapid_free(self, joints: Array) -> bool:
        """Joint-space straight moves through ``joints`` (k, 5) keep the rapid clearance."""
        key = np.ascontiguousarray(joints, dtype=np.float64).tobytes()
        known = self._rapids.get(key)
        if known is None:
            known = self._rapids[key] = self._rapid_free(joints)
        return known

    def _rapid_free(self, joints: Array) -> bool:
        r = self.rules
        samples = [joints[:1]]
        for q0, q1 in zip(joints[:-1], joints[1:], strict=True):
            # joint samples at most step_rad apart in A and C (the sub-samples between
            # them, step_mm apart on the chord, stay within R (1 - cos(step / 2)) of
            # the arc: 2e-3 mm at R = 200 mm for 0.5 deg), or step_mm in X, Y, Z
            span = max(float(np.abs(q1[:3] - q0[:3]).max()) / r.step_mm,
                       float(np.abs(q1[3:] - q0[3:]).max()) / r.step_rad)
            count = max(int(math.ceil(span)), 1)
            t = np.linspace(0.0, 1.0, count + 1)[1:, None]
            samples.append(q0 + t * (q1 - q0))
        q = np.vstack(samples)
        tip, axis = self.kins.forward(q)
        if len(tip) < 2:
            return True
        report = self.scene.check_motion(
            r.tool, tip, axis, max_step_mm=r.step_mm, max_step_deg=math.degrees(r.step_rad),
            cutter_allowance=-r.clearance, clearance_cap=r.clearance)
        return not bool(report.blocked(r.clearance).any())

    def feed_free(self, tip: Array, axis: Array, allowance: float | None = None,
                  driven: tuple[str, ...] | None = None) -> bool:
        """A feed move (W-linear, fixed axis) checked as a cut, cutter shrunk by allowance
        (against the roles not ``driven`` by at most ``rules.undriven_allowance``)."""
        r = self.rules
        scene: Any = self.scene
        if driven is not None and r.undriven_allowance is not None:
            from cam.finishing.driven import DrivenScene

            scene = DrivenScene(scene, driven, r.undriven_allowance)
        report = scene.check_motion(
            r.tool, tip, axis, max_step_mm=r.step_mm, max_step_deg=math.degrees(r.step_rad),
            cutter_allowance=r.cutter_allowance if allowance is None else allowance,
            clearance_cap=r.clearance)
        return not bool(report.blocked(r.clearance).any())

    def _reachable(self, tip: Array, axis: Array) -> bool:
        """Whether the machine reaches posture ``(tip, axis)`` inside its travel."""
        try:
            self.kins.inverse(np.reshape(tip, (1, 3)), np.reshape(axis, (1, 3)))
        except OverTravelError:
            return False
        return True

    def inverse(self, tip: Array, axis: Array, previous: Array) -> Array:
        return self.kins.inverse(np.reshape(tip, (-1, 3)), np.reshape(axis, (-1, 3)),
                                 previous=previous)

    # -- departures and approaches ---------------------------------------------------

    def escape(self, tip: Array, axis: Array, normal: Array) -> tuple[Array, float] | None:
        """The shortest clear departure point from posture ``(tip, axis)`` and its length.

        Candidates: ``DEPARTURE_SCALES`` x ``departure`` along the axis, the escape
        normal and their bisector; the first (shortest, then in that order) whose
        posture keeps the rapid clearance and whose feed move from ``tip`` is free.
        """
        r = self.rules
        directions = [axis, _unit(axis + normal), normal]
        lengths = np.array(DEPARTURE_SCALES) * r.departure
        points = np.array([[tip + length * d for d in directions] for length in lengths])
        flat = points.reshape(-1, 3)
        report = self.scene.check_postures(r.tool, flat, np.tile(axis, (len(flat), 1)),
                                           cutter_allowance=-r.clearance,
                                           clearance_cap=r.clearance)
        clear = ~report.blocked(r.clearance)
        for index in np.flatnonzero(clear):
            point = flat[index]
            if self.feed_free(np.stack([tip, point]), np.stack([axis, axis])):
                return point, float(lengths[index // len(directions)])
        return self._cutter_escape(tip, axis, flat, lengths, len(directions))

    def _cutter_escape(self, tip: Array, axis: Array, points: Array, lengths: Array,
                       per_length: int) -> tuple[Array, float] | None:
        """The shortest departure point ``escape`` found no clear one for whose moves
        out (to it, then along the axis to the clearance cylinder) the cutter makes as a
        cut: the fallback when the posture's own shank or holder is not clear.

        From a posture whose shank or holder already collides no departure is clear;
        the straight move along the axis could then drag the cutter through surfaces
        overhanging the ball. Shank and holder are not checked here: the posture is
        reported by the planner as a collision and no move from it is clear of them.
        None when every candidate's cutter meets the part (a posture whose own cutter
        is in the part: the pass is then left along its axis, unchecked, as before).
        """
        r = self.rules
        out = retract_length(points, np.tile(axis, (len(points), 1)), r.envelope, r.longest)
        for index, point in enumerate(points):
            far = point + out[index] * axis
            moves = np.stack([tip, point, far]) if out[index] > 0 else np.stack([tip, point])
            report = self.scene.check_motion(
                r.tool, moves, np.tile(axis, (len(moves), 1)), max_step_mm=r.step_mm,
                max_step_deg=math.degrees(r.step_rad), parts=("cutter",),
                cutter_allowance=r.cutter_allowance, clearance=False)
            if not bool(report.blocked().any()):
                return point, float(lengths[index // per_length])
        return None

    def feed_link(self, a: PassEnds, b: PassEnds) -> Stepover | None:
        """Pass ``a`` goes on into pass ``b`` at feed by this stepover (a zig-zag's
        tangent blend, else one straight move), or None (``stepover_blend``)."""
        return feed_stepover(self, a, b)

    # -- the operation ---------------------------------------------------------------

    def join(self, name: str, passes: Sequence[PassEnds], *, tool_number: int,
             cutter: Cutter, spindle_rpm: float | None
             ) -> tuple[Toolpath, NDArray[np.bool_], list[dict[str, Any]]]:
        """One operation: each pass with its departure and approach, linked.

        The links are chosen with joints from the inverse kinematics of their two
        ends; the post picks branches over the whole operation at once (least total
        travel), which can move a link otherwise. So the operation is built, its
        joints computed as the post will, every checked link whose joints moved is
        checked again, and a link that is no longer clear is rebuilt one kind up
        (direct -> clearance -> retract), up to ``_ROUNDS`` times; one still not clear
        after that is left to the post's retract and reported ``"demoted"``.

        Returns
        -------
        toolpath : Toolpath
            ``link`` flags the checked-link rapids.
        is_air : (m,) bool
            Poses whose incoming move is not a cut (approach, departure, link).
        links : list of dict
            Per link: ``from``, ``to``, ``kind`` (``"direct"``, ``"clearance"``,
            ``"retract"``: no checked link found, the post retracts to safe Z),
            ``departure_mm``, ``approach_mm`` (None: along the axis to the cylinder).
        """
        starts = [self.escape(p.tip[0], p.axis[0], p.escape_start) for p in passes]
        ends = [self.escape(p.tip[-1], p.axis[-1], p.escape_end) for p in passes]
        stepover = [None if b.from_air else self.feed_link(a, b)
                    for a, b in zip(passes[:-1], passes[1:], strict=True)]
        starts, ends, leads = tangent_leads(self, passes, starts, ends, stepover)
        floor: dict[int, int] = {}
        for _ in range(_ROUNDS):
            moves, air, reports, owner = self._build(passes, starts, ends, stepover, floor,
                                                      leads)
            tip = np.array(moves.tip)
            axis = _unit(np.array(moves.axis))
            link = np.array(moves.link, bool)
            bad = self._moved(tip, axis, link, moves.delta, np.array(moves.kind))
            raise_links = {owner[row] for row in bad if owner[row] >= 0}
            if not raise_links:
                break
            for k in raise_links:
                floor[k] = _LEVELS.index(reports[k]["kind"]) + 1
        for row in bad:
            link[row] = False
            reports.append({"kind": "demoted", "row": int(row),
                            "note": "the post's joints move this checked rapid otherwise "
                                    "and it is not clear: left to the post's safe retract"})
        toolpath = Toolpath(
            tip=tip, axis=axis, feed=np.array(moves.feed), kind=np.array(moves.kind, np.int8),
            name=name, tool_number=tool_number, cutter=cutter, spindle_rpm=spindle_rpm,
            link=link)
        return toolpath, np.array(air, bool), reports

    def _build(self, passes: Sequence[PassEnds], starts: list[tuple[Array, float] | None],
               ends: list[tuple[Array, float] | None], stepover: list[Stepover | None],
               floor: dict[int, int],
               leads: tuple[list[Lead | None], list[Lead | None]] = ([], [])
               ) -> tuple[_Moves, list[bool], list[dict[str, Any]], dict[int, int]]:
        """The operation's poses; ``stepover[k]``: pass k goes on into pass k + 1 at
        feed; ``floor[k]``: lowest kind index for link k; ``leads``: per pass the
        tangent approach's and departure's postures (``lead_blend``; None: straight)."""
        r = self.rules
        moves = _Moves()
        air: list[bool] = []
        reports: list[dict[str, Any]] = []
        owner: dict[int, int] = {}  # checked-link row -> link index (-1: in or out)
        half = 0.5 * r.feed

        def add(tip: Array, axis: Array, kind: MoveKind, feed: float, link: bool,
                is_air: bool, joints: Array | None = None) -> None:
            before = len(moves.tip)
            moves.add(tip, axis, kind, feed, link, joints)
            air.extend([is_air] * (len(moves.tip) - before))
            for row in range(before, len(moves.tip)):
                owner[row] = len(reports) if link else -1

        def ends_way(way: list[AxialMove], axis: Array) -> None:
            # the operation's way in or out (``axial_moves``): not a link of the report
            for move in way:
                before = len(moves.tip)
                add(move.tip, axis, move.kind, move.feed, move.link, True, move.joints)
                owner[before] = -1

        exit_point: tuple[Array, Array, Array, float | None] | None = None
        previous_name = ""
        for index, p in enumerate(passes):
            start = starts[index]
            outer_in = p.tip[0] + retract_length(p.tip[:1], p.axis[:1], r.envelope,
                                                 r.longest)[0] * p.axis[0]
            entry = start[0] if start is not None else outer_in
            approach_mm = None if start is None else start[1]
            step = stepover[index - 1] if index else None
            if step is not None:
                # the stepover at feed into this pass, no departure, link or approach
                reports.append({"from": previous_name, "to": p.name, "kind": "feed",
                                "departure_mm": None, "approach_mm": round(float(
                                    np.linalg.norm(p.tip[0] - passes[index - 1].tip[-1])), 4),
                                "blend_reach_mm": round(step.reach, 4)})
            elif exit_point is None:
                # first pass: the post positions above the cylinder point, then in; a
                # cylinder point beyond the machine's travel is left out (the post's
                # own positioning comes down the tool axis to the entry instead)
                if not self._reachable(outer_in, p.axis[0]):
                    outer_in = entry
                add(outer_in, p.axis[0], MoveKind.RAPID, math.nan, False, True)
                if start is not None and outer_in is not entry:
                    ends_way(axial_moves(self, outer_in, entry, p.axis[0], p.joints_start,
                                         inward=True), p.axis[0])
            else:
                kind = self._link(exit_point, (entry, p.axis[0], p.joints_start), add,
                                  floor.get(len(reports), 0))
                reports.append({"from": previous_name, "to": p.name, "kind": kind,
                                "departure_mm": exit_point[3], "approach_mm": approach_mm})
            if step is not None and step.blended:  # the blend up to the pass's start
                add(step.tip[:-1], step.axis[:-1], MoveKind.PLUNGE, r.feed, False, True)
            curve = leads[0][index] if step is None and leads[0] else None
            if curve is not None:  # the tangent approach up to the pass's start
                add(curve[0][:-1], curve[1][:-1], MoveKind.PLUNGE, r.feed, False, True)
            add(p.tip[0], p.axis[0], MoveKind.PLUNGE,
                r.feed if start is not None or step is not None else half, False, True)
            add(p.tip[1:], p.axis[1:], MoveKind.FEED, r.feed, False, False)
            end = ends[index]
            previous_name = p.name
            if index < len(passes) - 1 and stepover[index] is not None:
                exit_point = (p.tip[-1], p.axis[-1], p.joints_end, 0.0)
                continue
            if end is not None:
                exit_point = (end[0], p.axis[-1], p.joints_end, end[1])
                curve = leads[1][index] if leads[1] else None
                if curve is not None:  # the tangent departure up to its end
                    add(curve[0][:-1], curve[1][:-1], MoveKind.RETRACT, r.feed, False, True)
                add(end[0], p.axis[-1], MoveKind.RETRACT, r.feed, False, True)
            else:
                out = p.tip[-1] + retract_length(p.tip[-1:], p.axis[-1:], r.envelope,
                                                 r.longest)[0] * p.axis[-1]
                exit_point = (out, p.axis[-1], p.joints_end, None)
                add(out, p.axis[-1], MoveKind.RETRACT, half, False, True)
            if index == len(passes) - 1 and exit_point[3] is not None:
                outer = exit_point[0] + retract_length(
                    exit_point[0][None], exit_point[1][None], r.envelope, r.longest)[0] \
                    * exit_point[1]
                if not self._reachable(outer, exit_point[1]):
                    break  # beyond the travel: the post's end retract leaves from here
                ends_way(axial_moves(self, exit_point[0], outer, exit_point[1],
                                     p.joints_end, inward=False), exit_point[1])
        return moves, air, reports, owner

    def _moved(self, tip: Array, axis: Array, link: NDArray[np.bool_],
               delta: dict[int, Array], kind: NDArray[np.int8]) -> list[int]:
        """Checked-link rows the post's joints (the whole operation's inverse kinematics,
        feed moves kept on their branch as the post keeps them: ``keeps_branch``) move
        otherwise than the pair they were checked with, and that are not clear.

        When the machine cannot reach some pose of the operation (a retract beyond its
        travel), no program can be posted from it (the post refuses it with the same
        over-travel error), so there is nothing to re-check here.
        """
        keep = keeps_branch(axis, kind != MoveKind.RAPID, DEFAULT_TOLERANCES.angular)
        try:
            joints = self.kins.inverse(tip, axis, keep_branch=keep if keep.any() else None)
        except OverTravelError:
            return []
        bad = []
        for row in np.flatnonzero(link).tolist():
            step = joints[row] - joints[row - 1]
            if np.allclose(step, delta[row], rtol=0.0, atol=1e-9):
                continue
            if not self.rapid_free(joints[row - 1:row + 1]):
                bad.append(int(row))
        return bad

    def _link(self, exit_point: tuple[Array, Array, Array, float | None],
              entry: tuple[Array, Array, Array], add: Any, level: int = 0) -> str:
        """Append the link from ``exit_point`` to ``entry``, of kind ``_LEVELS[level]``
        or higher; returns its kind."""
        r = self.rules
        a_tip, a_axis, a_joints, _ = exit_point
        b_tip, b_axis, _ = entry
        q = self.inverse(np.stack([a_tip, b_tip]), np.stack([a_axis, b_axis]), a_joints)
        if level <= 0 and self.rapid_free(q):
            add(b_tip, b_axis, MoveKind.RAPID, math.nan, True, True, q)
            return "direct"
        lengths = retract_length(np.stack([a_tip, b_tip]), np.stack([a_axis, b_axis]),
                                 r.envelope, r.longest)
        a_out = a_tip + lengths[0] * a_axis
        b_out = b_tip + lengths[1] * b_axis
        tips = np.stack([a_tip, a_out, b_out, b_tip])
        axes = np.stack([a_axis, a_axis, b_axis, b_axis])
        joints: Array | None
        try:
            joints = self.inverse(tips, axes, a_joints)
        except OverTravelError:  # the cylinder points lie beyond the machine's travel
            joints = None
        free = [joints is not None and self.rapid_free(joints[i:i + 2]) for i in range(3)]
        if level <= 1 and all(free):
            add(tips[1:], axes[1:], MoveKind.RAPID, math.nan, True, True, joints)
            return "clearance"
        # no checked link: out (checked rapid, else at half feed), the earlier
        # stepped turn as plain rapids (the post retracts around them), in again
        half = 0.5 * r.feed
        if lengths[0] > 0:
            add(a_out, a_axis, MoveKind.RAPID if free[0] else MoveKind.RETRACT,
                math.nan if free[0] else half, free[0], True,
                None if joints is None else joints[0:2])
        link_tip, link_axis = stepped_link(a_out, a_axis, b_out, b_axis, r.turn_step)
        add(np.vstack([link_tip, b_out[None]]), np.vstack([link_axis, b_axis[None]]),
            MoveKind.RAPID, math.nan, False, True)
        if lengths[1] > 0:
            add(b_tip, b_axis, MoveKind.RAPID if free[2] else MoveKind.PLUNGE,
                math.nan if free[2] else half, free[2], True,
                None if joints is None else joints[2:4])
        return "retract"
