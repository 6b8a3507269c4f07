"""The machine model as an obstacle for planning: clearances of a batch of poses.

The verifier (``cam.verify.machine_check``) walks a posted program block by block.
A planner asks other questions: "do these postures (cone candidates, a path, a link)
keep every checked pair of the machine's solids its clearance, and by how much?".
``MachineClearance`` answers them for joint vectors ``(n, 5)`` with the verifier's own
scene (``MachineScene``: the machine's solids, the job's tool, holder, part and
fixture, the checked pairs and their clearances) and the verifier's own exact
distance (``machine_scene._distance``: fcl on the same objects), so a pose gets the
same distance in planning and in verification.

Cost: the certified lower bounds of ``cam.verify.machine_bounds`` (bounding spheres,
conservative advancement along the rows, GJK on the solids' convex point sets, all in
one compiled pass over the poses and pairs), and fcl only where a bound stays below
the pair's clearance plus ``cap``: every distance below that is fcl's own, so the
answers are those of a plain fcl loop over every pose and pair.

``postures_margin`` turns tool postures in W into joints with both branches of the
inverse kinematics that lie inside the tilt limits, and keeps the smaller margin:
the post may take either branch, the planner must be right for both.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.verify.machine_bounds import ADVANCE_SLACK, pack_solids, pair_bounds, stack_poses
from cam.verify.machine_scene import MachineScene, _distance, _radii
from postproc.machine_model import TOOL_SIDE, group_poses

__all__ = ["Clearances", "MachineClearance", "joint_path_samples"]

Array = NDArray[np.float64]
TOOL_SIDE_GROUPS = frozenset(TOOL_SIDE)


@dataclass
class Clearances:
    """Distances of every checked pair at a batch of poses.

    Attributes
    ----------
    distance : (n, p) float64
        Distance per pose and checked pair, mm: exact (fcl) where ``exact``, else a
        lower bound that is at least the pair's clearance plus the query's ``cap``.
    exact : (n, p) bool
    clearance : (p,) float64
        The pairs' clearances, mm.
    names : list of (str, str)
        The pairs' component names.
    """

    distance: Array
    exact: NDArray[np.bool_]
    clearance: Array
    names: list[tuple[str, str]]

    @property
    def margin(self) -> Array:
        """Smallest ``distance - clearance`` over the pairs per pose, mm ``(n,)``."""
        if not len(self.clearance):
            return np.full(len(self.distance), math.inf)
        return np.asarray((self.distance - self.clearance[None, :]).min(axis=1))

    @property
    def worst_pair(self) -> NDArray[np.intp]:
        """Index of the pair with the smallest margin per pose ``(n,)``."""
        if not len(self.clearance):
            return np.zeros(len(self.distance), dtype=np.intp)
        return np.asarray(np.argmin(self.distance - self.clearance[None, :], axis=1))


class MachineClearance:
    """Planning-side clearance query on one ``MachineScene`` (one tool).

    Parameters
    ----------
    scene : MachineScene
        From ``machine_scene.machine_scene`` (the tool, holder, part and fixture
        solids are the verifier's).
    kins : TableTiltingRotary
        The machine's kinematics.
    tool_side : bool
        Only the pairs with a solid on the spindle side (X, Y, Z groups: spindle,
        tool, holder): what moving the tool can change. Pairs of two table-side
        solids (the part or the platter against the cradle) are the machine's own
        build; the verifier reports them.

    Attributes
    ----------
    queries : int
        fcl distance queries made so far.
    poses : int
        Poses asked about so far.
    seconds : float
        Process time spent in the queries, s.
    """

    def __init__(self, scene: MachineScene, kins: Any, tool_side: bool = False) -> None:
        self.scene = scene
        self.kins = kins
        self.pairs = [p for p in scene.pairs if not tool_side
                      or TOOL_SIDE_GROUPS & {scene.solids[p[0]].group, scene.solids[p[1]].group}]
        self.clearance = np.array([c for _, _, c in self.pairs], dtype=np.float64)
        self.names = [(scene.solids[i].name, scene.solids[j].name) for i, j, _ in self.pairs]
        self.radius = np.array([s.radius for s in scene.solids])
        self.centre = np.array([s.centre for s in scene.solids])
        self.rho = _radii(scene, kins)
        self.packed = pack_solids(scene.solids, scene.tilt)
        self._first = np.array([i for i, _, _ in self.pairs], dtype=np.int64)
        self._second = np.array([j for _, j, _ in self.pairs], dtype=np.int64)
        pieces = np.diff(self.packed.solid_start)
        slots = max([int(pieces[i] * pieces[j]) for i, j, _ in self.pairs], default=1)
        # start directions of the bounds' GJK per pair and piece pair (kept between calls)
        self.guesses = np.zeros((len(self.pairs), slots, 3))
        self.queries = 0
        self.poses = 0
        self.seconds = 0.0

    # -- joints ------------------------------------------------------------------------

    def query(self, joints: Array, cap: float = 0.0) -> Clearances:
        """Distances of every checked pair at ``joints`` (n, 5) (X Y Z mm, A C rad).

        Exact where a distance is below the pair's clearance plus ``cap`` (mm); rows
        are taken as a sequence (conservative advancement from row to row).
        """
        started = time.process_time()
        joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
        n, p = len(joints), len(self.pairs)
        distance = np.full((n, p), math.inf)
        exact = np.zeros((n, p), dtype=bool)
        if n and p:
            poses = group_poses(self.kins, joints, self.scene.gauge, self.scene.tilt)
            value, certain, _ = self._bounds(joints, poses, self.clearance + cap, False,
                                             math.inf)
            distance[:] = value
            for row, k in zip(*np.nonzero(~certain), strict=True):
                i, j, _ = self.pairs[int(k)]
                distance[row, k] = _distance(self.scene, poses, i, j, int(row))
                exact[row, k] = True
            self.queries += int((~certain).sum())
        self.poses += n
        self.seconds += time.process_time() - started
        return Clearances(distance, exact, self.clearance, self.names)

    def smallest(self, joints: Array, result: Clearances | None = None
                 ) -> tuple[float, tuple[str, str], int]:
        """The smallest exact distance of any checked pair over ``joints`` (n, 5).

        Returns ``(distance mm, pair names, row)``; ``(inf, ("", ""), -1)`` without
        poses or pairs. Every entry whose certified lower bound is not above the
        smallest upper bound (``machine_bounds``, tight mode) is measured, so the
        minimum and its row are the plain fcl loop's. ``result``: this query's own
        ``query(joints)`` when the caller has it already (refined in place).
        """
        if result is None:
            return self.survey(joints)[1]
        return self._tight(joints, result)

    def survey(self, joints: Array) -> tuple[Clearances, tuple[float, tuple[str, str], int]]:
        """``query(joints)`` and ``smallest(joints)`` in one pass over the bounds."""
        joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
        n, p = len(joints), len(self.pairs)
        result = Clearances(np.full((n, p), -math.inf), np.zeros((n, p), dtype=bool),
                            self.clearance, self.names)
        self.poses += n
        return result, self._tight(joints, result)

    def _tight(self, joints: Array, result: Clearances) -> tuple[float, tuple[str, str], int]:
        """Tight bounds over ``joints``; every entry below its clearance or that can
        hold the minimum measured into ``result``; the minimum."""
        distance, exact = result.distance, result.exact
        if not distance.size:
            return math.inf, ("", ""), -1
        started = time.process_time()
        joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
        poses = group_poses(self.kins, joints, self.scene.gauge, self.scene.tilt)
        known = float(np.where(exact, distance, math.inf).min())
        value, certain, _ = self._bounds(joints, poses, self.clearance, True, known)
        np.maximum(distance, value, out=distance, where=~exact)  # both lower bounds
        for row, k in zip(*np.nonzero(~certain & ~exact), strict=True):
            i, j, _ = self.pairs[int(k)]
            distance[row, k] = _distance(self.scene, poses, i, j, int(row))
            exact[row, k] = True
            self.queries += 1
        self.seconds += time.process_time() - started
        row, k = np.unravel_index(int(np.argmin(np.where(exact, distance, math.inf))),
                                  distance.shape)
        return float(distance[row, k]), self.names[int(k)], int(row)

    # -- postures ----------------------------------------------------------------------

    def postures_margin(self, tip: Array, axis: Array, cap: float = 0.0
                        ) -> tuple[Array, NDArray[np.intp]]:
        """Smallest margin (distance - clearance, mm) per posture in W, and its pair.

        Both inverse branches inside the tilt limits are checked (the smaller margin
        wins); a posture no branch reaches gets ``inf`` (the travel check reports it).

        Parameters
        ----------
        tip, axis : (n, 3) float64
            Tool tips (mm) and unit axes in W.
        cap : float
            Margins below ``cap`` are exact, mm.
        """
        tip = np.asarray(tip, dtype=np.float64).reshape(-1, 3)
        axis = np.asarray(axis, dtype=np.float64).reshape(-1, 3)
        n = len(tip)
        margin = np.full(n, math.inf)
        worst = np.zeros(n, dtype=np.intp)
        if not n or not self.pairs:
            return margin, worst
        branches = self.kins.inverse_branches(tip, axis)  # (2, n, 5)
        lower, upper = self.kins.machine.limits()
        for branch in branches:
            inside = (branch[:, 3] >= lower[3] - 1e-9) & (branch[:, 3] <= upper[3] + 1e-9)
            rows = np.flatnonzero(inside)
            if not rows.size:
                continue
            found = self.query(branch[rows], cap)
            value = found.margin
            lower_now = value < margin[rows]
            margin[rows[lower_now]] = value[lower_now]
            worst[rows[lower_now]] = found.worst_pair[lower_now]
        return margin, worst

    # -- internals ---------------------------------------------------------------------

    def _bounds(self, joints: Array, poses: dict[str, Any], limit: Array, tight: bool,
                best: float) -> tuple[Array, NDArray[np.bool_], float]:
        """``machine_bounds.pair_bounds`` of every pair at ``joints`` (rows in order)."""
        rot, trans = stack_poses(poses, self.packed.groups)
        packed = self.packed
        return pair_bounds(  # type: ignore[no-any-return]
            packed.points, packed.piece_start, packed.piece_centre, packed.piece_radius,
            packed.piece_cylinder, packed.solid_box, packed.solid_start, packed.solid_group,
            packed.solid_excess, self.centre, self.radius,
            self._first, self._second, np.ascontiguousarray(limit, dtype=np.float64), rot,
            trans, np.ascontiguousarray(joints, dtype=np.float64), self.guesses, tight, best,
            ADVANCE_SLACK)


def joint_path_samples(joints: Array, step: float, rho: dict[str, float], *,
                       with_starts: bool = False) -> Any:
    """Joint-linear samples through ``joints`` (k, 5) as the verifier samples a block.

    Each move gets ``ceil((|delta XYZ| + rho_tilt |delta tilt| + rho_C |delta C|) /
    step)`` sub-steps (``machine_check._sample_plan``), so that no machine point moves
    more than ``step`` (mm) between samples.

    Returns
    -------
    samples : (m, 5) float64
        The rows of ``joints`` and the sub-steps between them.
    starts : (k,) int64
        Index of each row of ``joints`` among the samples (with ``with_starts``).
    """
    joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
    if len(joints) < 2:
        samples = joints.copy()
        return (samples, np.zeros(len(joints), np.int64)) if with_starts else samples
    delta = np.diff(joints, axis=0)
    bound = (np.linalg.norm(delta[:, :3], axis=1) + rho["tilt"] * np.abs(delta[:, 3])
             + rho["C"] * np.abs(delta[:, 4]))
    count = np.clip(np.ceil(bound / step), 1, 4096).astype(np.int64)
    start = np.repeat(np.arange(len(delta)), count)
    first = np.cumsum(count) - count
    frac = (np.arange(int(count.sum())) - np.repeat(first, count) + 1) / np.repeat(count, count)
    samples = np.vstack([joints[:1], joints[start] + frac[:, None] * delta[start]])
    if not with_starts:
        return samples
    return samples, np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
