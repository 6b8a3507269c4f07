"""The machine model as an obstacle of the finishing planner (issue 29).

``MachineObstacle`` is a ``CollisionScene`` to the planner, built around the part's
scene (the design, or the design with the in-process stock): every posture and
motion it is asked about is checked as before and, in addition, against the machine
file's ``[model]`` with the verifier's solids (``cam.verify.machine_query``): a
posture where some checked pair of the machine (spindle head and rotary table,
spindle nose and the part, ...) comes closer than the pair's clearance plus
``margin`` collides, with the scene role ``MACHINE_ROLE``. So the planner's own
machinery handles it like a shank or holder collision: the eq. 7 remedy turns C, the
posture repair (``cam.finishing.repair``) tilts the axis away, open-ended passes are
trimmed, links go another way (``cam.finishing.linking``), and what is still
blocked is named in finish.json.

Only pairs with a spindle-side solid (spindle, tool, holder) are the planner's:
moving the tool changes them; two table-side solids (the part against the cradle)
are the machine's own build, reported by the verifier.

``margin`` covers the motion between the planner's samples and the verifier's: the
motion between two postures is checked at joint-linear samples no machine point
moves more than the model's ``step`` between (as the verifier samples a block), so a
pair between two samples is at most ``step / 2`` closer than at the nearer one; the
default margin is ``step / 2``.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam.collision import PART_NAMES, CollisionScene
from cam.collision.scene import PostureReport
from cam.collision.scene_wrapper import SceneWrapper
from cam.verify.machine_query import MachineClearance, joint_path_samples
from cam.verify.machine_scene import machine_scene
from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.pole import keeps_branch

if TYPE_CHECKING:
    from cam.tools import Tool
    from postproc.machine_model import MachineModel, Solid
    from postproc.toolpath import Toolpath

__all__ = ["MACHINE_ROLE", "MachineObstacle", "continuous_branches", "operation_clearance"]

#: Scene role of a machine collision in posture reports.
MACHINE_ROLE = "machine"
#: Part index reported for a machine collision (the holder's: the spindle side).
_MACHINE_PART = 2

Array = NDArray[np.float64]


class MachineObstacle(SceneWrapper, CollisionScene):
    """The part's scene and the machine model as one (module docstring).

    It does not run ``CollisionScene.__init__``; every attribute it does not define
    is the wrapped scene's.

    Parameters
    ----------
    inner : CollisionScene
        The part's scene (design, or ``StockScene``).
    model : MachineModel
        The machine file's ``[model]``.
    kins : TableTiltingRotary
        The machine's kinematics.
    part : Solid
        The part's solid as the verifier builds it (``machine_scene.part_solid``).
    margin : float, optional
        Extra distance kept beyond every pair's clearance, mm (default ``step / 2``).
    """

    def __init__(self, inner: CollisionScene, model: MachineModel, kins: Any, part: Solid,
                 margin: float | None = None) -> None:
        self.inner = inner
        self.model = model
        self.kins = kins
        self.part = part
        self.margin = 0.5 * model.step if margin is None else float(margin)
        self.queries: dict[str, MachineClearance] = {}
        self.every: dict[str, MachineClearance] = {}
        #: ``posture_blocked``'s answers by tool name and the postures' bytes (the
        #: planner's last check of a path's postures is asked again for finish.json)
        self._blocked: dict[tuple[str, bytes, bytes], NDArray[np.bool_]] = {}
        self._planner_tools: dict[str, Tool] = {}  # the tools of ``queries``

    def query(self, tool: Tool) -> MachineClearance:
        """The clearance query of ``tool`` (cached per tool name)."""
        found = self.queries.get(tool.name)
        if found is None:
            scene = machine_scene(self.model, tool, None, part=self.part)
            found = self.queries[tool.name] = MachineClearance(scene, self.kins,
                                                               tool_side=True)
            self._planner_tools[tool.name] = tool
        return found

    def query_every(self, tool: Tool) -> MachineClearance:
        """The clearance query of ``tool`` over every checked pair, the table side's
        too (the verifier's; cached per tool name)."""
        found = self.every.get(tool.name)
        if found is None:
            found = self.every[tool.name] = MachineClearance(self.query(tool).scene, self.kins)
        return found

    @property
    def stats(self) -> dict[str, float]:
        """Poses asked, fcl queries, process seconds of the planner's machine queries
        (all tools; not ``query_every``'s, which serves finish.json's operations)."""
        queries = list(self.queries.values())
        return {"poses": sum(q.poses for q in queries),
                "distance_queries": sum(q.queries for q in queries),
                "seconds": sum(q.seconds for q in queries)}

    # -- what a forked planner hands back (``impeller_cam.processes``) ---------------

    def fork_mark(self) -> Any:
        """The planner's query counts per tool, the number of kept answers and what the
        wrapped scenes have built, now."""
        return ({name: (q.poses, q.queries, q.seconds) for name, q in self.queries.items()},
                len(self._blocked), CollisionScene.fork_mark(self))

    def fork_delta(self, mark: Any) -> Any:
        """What the planner's queries counted, ``posture_blocked`` kept and the wrapped
        scenes built since ``mark`` (``fork_mark``): ``{"tools", "counts", "blocked",
        "built"}``, to pickle."""
        counts, kept, built = mark
        delta = {}
        for name, q in self.queries.items():
            poses, queries, seconds = counts.get(name, (0, 0, 0.0))
            delta[name] = (q.poses - poses, q.queries - queries, q.seconds - seconds)
        # ``query_every`` asks ``query`` first: its tools are among ``delta``'s
        tools = {name: self._planner_tools[name] for name in delta}
        return {"tools": tools, "counts": delta, "every": list(self.every),
                "blocked": dict(list(self._blocked.items())[kept:]),
                "built": CollisionScene.fork_delta(self, built)}

    def merge_fork_delta(self, delta: Any) -> None:
        """Add a forked planner's ``fork_delta`` to this obstacle's counts and kept
        answers, as if its queries had run here, and build here what it built (the
        next fork inherits it instead of building it again)."""
        for name, (poses, queries, seconds) in delta["counts"].items():
            q = self.query(delta["tools"][name])
            q.poses += poses
            q.queries += queries
            q.seconds += seconds
        for key, value in delta["blocked"].items():
            self._blocked.setdefault(key, value)
        for name in delta["every"]:
            self.query_every(delta["tools"][name])
        CollisionScene.merge_fork_delta(self, delta["built"])

    # -- checks ------------------------------------------------------------------------

    def posture_margin(self, tool: Tool, tip: ArrayLike, axis: ArrayLike) -> Array:
        """Smallest ``distance - clearance`` of the machine's pairs per posture, mm."""
        margin, _ = self.query(tool).postures_margin(
            np.asarray(tip, np.float64), np.asarray(axis, np.float64), cap=self.margin)
        return margin

    def posture_blocked(self, tool: Tool, tip: ArrayLike, axis: ArrayLike
                        ) -> NDArray[np.bool_]:
        """Postures where a machine pair comes within its clearance plus ``margin``
        (``posture_margin < margin``), ``(n,)`` bool.

        The same postures asked again (the same tool, bit for bit the same tips and
        axes) get the answer already found: the margins below ``margin`` are exact, so
        the comparison is the same whichever bounds decided the rest.
        """
        tip = np.ascontiguousarray(tip, dtype=np.float64).reshape(-1, 3)
        axis = np.ascontiguousarray(axis, dtype=np.float64).reshape(-1, 3)
        key = (tool.name, tip.tobytes(), axis.tobytes())
        found = self._blocked.get(key)
        if found is None:
            found = self._blocked[key] = self.posture_margin(tool, tip, axis) < self.margin
        return found.copy()

    def motion_margin(self, tool: Tool, tip: ArrayLike, axis: ArrayLike) -> Array:
        """Smallest margin per motion segment ``i -> i + 1`` (joint-linear samples, both
        inverse branches inside the tilt limits, each followed as the post follows it:
        a move whose axis keeps off the C axis stays on its branch, one that passes
        it takes the nearer solution; ``continuous_branches``), mm ``(n - 1,)``."""
        tip = np.asarray(tip, np.float64).reshape(-1, 3)
        axis = np.asarray(axis, np.float64).reshape(-1, 3)
        query = self.query(tool)
        n = len(tip)
        out = np.full(max(n - 1, 0), math.inf)
        if n < 2 or not query.pairs:
            return out
        lower, upper = self.kins.machine.limits()
        for branch in continuous_branches(self.kins.inverse_branches(tip, axis), axis):
            joints = branch.copy()
            joints[:, 4] = np.unwrap(joints[:, 4])
            inside = (joints[:, 3] >= lower[3] - 1e-9) & (joints[:, 3] <= upper[3] + 1e-9)
            usable = inside[:-1] & inside[1:]
            if not usable.any():
                continue
            samples, starts = joint_path_samples(joints, self.model.step, query.rho,
                                                 with_starts=True)
            margin = query.query(samples, cap=self.margin).margin
            seg = np.minimum(np.minimum.reduceat(margin, starts[:-1]), margin[starts[1:]])
            out = np.where(usable, np.minimum(out, seg), out)
        return out

    def _combine(self, report: PostureReport, blocked: NDArray[np.bool_]) -> PostureReport:
        if not blocked.any():
            return report
        own = np.asarray(report.collides, dtype=bool)
        collides = own | blocked
        part = np.where(own, report.part, np.where(blocked, _MACHINE_PART, -1)).astype(np.int8)
        roles = [r if c else (MACHINE_ROLE if b else None)
                 for r, c, b in zip(report.hit_role, own, blocked, strict=True)]
        checks = dict(report.checks, machine_blocked=int(blocked.sum()))
        return PostureReport(collides, part, roles, report.clearance, report.bound, checks)

    def check_postures(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                       parts: Collection[str] = PART_NAMES,
                       cutter_allowance: float = 0.0,
                       cutter_roles: Collection[str] | None = None, clearance: bool = True,
                       clearance_cap: float = math.inf,
                       clearance_limits: Sequence[float] = ()) -> PostureReport:
        """``CollisionScene.check_postures``; machine pairs within their clearance plus
        ``margin`` collide (role ``MACHINE_ROLE``)."""
        report = self.inner.check_postures(
            tool, tip, axis, parts=parts, cutter_allowance=cutter_allowance,
            cutter_roles=cutter_roles, clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits)
        return self._combine(report, self.posture_blocked(tool, tip, axis))

    def check_motion(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                     max_step_mm: float, max_step_deg: float,
                     parts: Collection[str] = PART_NAMES,
                     cutter_allowance: float = 0.0,
                     cutter_roles: Collection[str] | None = None, clearance: bool = True,
                     clearance_cap: float = math.inf,
                     clearance_limits: Sequence[float] = (),
                     ends: PostureReport | None = None) -> PostureReport:
        """``CollisionScene.check_motion``; a segment along which a machine pair comes
        within its clearance plus ``margin`` collides (role ``MACHINE_ROLE``)."""
        report = self.inner.check_motion(
            tool, tip, axis, max_step_mm=max_step_mm, max_step_deg=max_step_deg,
            parts=parts, cutter_allowance=cutter_allowance, cutter_roles=cutter_roles,
            clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits, ends=ends)
        return self._combine(report, self.motion_margin(tool, tip, axis) < self.margin)


def continuous_branches(branches: Array, axis: Array | None = None) -> Array:
    """The two inverse solutions of a posture sequence, each followed continuously.

    ``inverse_branches`` lists the tilt >= 0 solution first at every posture; where a
    path's axis passes through the C axis the joints the post computes change the
    sign of the tilt (A through 0, C almost unchanged), so the tilt-sign branches
    would jump C by about 180 deg there: a move no program makes. Here each sequence
    takes, at every posture, the solution nearer (``|dA| + |dC|``, C modulo a turn)
    to its own at the posture before; the two sequences are mirror images, so the
    choice made for the first decides the second.

    A feed move whose great circle keeps farther than the angular tolerance from the
    C axis stays on its branch in the post (``postproc.pole.keeps_branch``), however
    far C then turns: given the postures' ``axis``, such moves never change sequence
    here (the splitter's round-2 rest stepover turned C by 125 deg there, and its
    holder met the mandrel nut where the nearer solution saw none).

    Parameters
    ----------
    branches : (2, n, 5) float64
        Both solutions per posture (X Y Z mm, A C rad).
    axis : (n, 3) float64, optional
        The postures' unit tool axes in W: every move is a cut, and only those that
        pass within the angular tolerance of the C axis may change sequence.

    Returns
    -------
    (2, n, 5) float64
        The same solutions, swapped per posture so that each row is continuous.
    """
    first, second = branches[0], branches[1]

    def change(a: Array, b: Array) -> Array:
        turn = np.abs(np.angle(np.exp(1j * (b[:, 4] - a[:, 4]))))
        return np.asarray(np.abs(b[:, 3] - a[:, 3]) + turn)

    swap = change(first[:-1], second[1:]) < change(first[:-1], first[1:])
    if axis is not None and swap.any():  # the pole test only where the nearer swaps
        keep = keeps_branch(np.asarray(axis, dtype=np.float64),
                            np.concatenate([[False], swap]), DEFAULT_TOLERANCES.angular)
        swap &= ~keep[1:]
    odd = np.concatenate([[False], np.cumsum(swap) % 2 == 1])
    return np.stack([np.where(odd[:, None], second, first),
                     np.where(odd[:, None], first, second)])


def operation_clearance(obstacle: MachineObstacle, tool: Tool, toolpath: Toolpath
                        ) -> dict[str, Any]:
    """finish.json's machine entry of one operation, as the post will move it.

    The joints are the post's (the inverse kinematics over the whole operation: its
    branches, C winding and feed moves kept on their branch), sampled joint-linearly as
    the verifier samples the blocks (``joint_path_samples``); every checked pair, as the
    verifier's. A plain rapid that turns a rotary axis is moved as the post moves it:
    retract to the machine's safe Z (the top of its Z travel), orient, position, down
    (``postproc.posting.guarded_rapids``, ``safety_joints``).

    Parameters
    ----------
    toolpath : Toolpath
        The operation's poses in W (cuts, departures, links, approaches), their kinds
        and checked links.

    Returns
    -------
    dict
        ``machine_clearance_mm`` (smallest distance of any checked pair),
        ``machine_clearance_pair``, ``machine_clearance_pose`` (index of the pose the
        move to which holds it), ``machine_collision_moves`` (moves along which a pair
        comes closer than its clearance: 0 when planning and verification agree).
    """
    from postproc.kinematics.base import OverTravelError
    from postproc.pole import keeps_branch
    from postproc.safe_retract import guarded_rapids, safety_joints
    from postproc.toolpath import MoveKind

    query = obstacle.query_every(tool)
    tip = np.asarray(toolpath.tip, np.float64)
    axis = np.asarray(toolpath.axis, np.float64)
    keep = keeps_branch(axis, toolpath.kind != MoveKind.RAPID, DEFAULT_TOLERANCES.angular)
    try:
        joints = obstacle.kins.inverse(tip, axis, keep_branch=keep if keep.any() else None)
    except OverTravelError as error:
        return {"machine_clearance_mm": None, "note": f"not reachable: {error}"}
    guarded = guarded_rapids(joints, toolpath.kind == MoveKind.RAPID, toolpath.link)
    z_safe = float(obstacle.kins.machine.limits()[1][2])
    rows: list[Array] = []
    pose: list[int] = []  # per row of ``rows``: the pose whose move it belongs to
    start = 0
    for j in guarded.tolist() + [len(joints)]:
        rows.append(joints[start:j])
        pose.extend(range(start, j))
        if j < len(joints):
            rows.append(safety_joints(joints[j - 1], joints[j], z_safe, z_safe))
            pose.extend([j] * 3)
        start = j
    moved = np.vstack(rows)
    owner = np.asarray(pose, np.int64)
    samples, starts = joint_path_samples(moved, obstacle.model.step, query.rho,
                                         with_starts=True)
    found, (smallest, pair, row) = query.survey(samples)
    below = found.margin < 0.0  # exact wherever a pair is within its clearance
    if not math.isfinite(smallest):
        return {"machine_clearance_mm": None}
    move = owner[np.searchsorted(starts, np.flatnonzero(below), side="left")]
    return {"machine_clearance_mm": round(smallest, 3),
            "machine_clearance_pair": list(pair),
            "machine_clearance_pose": int(owner[np.searchsorted(starts, row, side="left")]),
            "machine_collision_moves": int(len(np.unique(move))),
            "guarded_rapids": int(len(guarded))}
