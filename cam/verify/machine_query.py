"""The machine model as an obstacle for planning: clearances of a batch of poses.

The verifier (``cam.verify.machine_check``) walks a posted program block by block.
A planner asks other questions: "do these postures (cone candidates, a path, a link)
keep every checked pair of the machine's solids its clearance, and by how much?".
``MachineClearance`` answers them for joint vectors ``(n, 5)`` with the verifier's own
scene (``MachineScene``: the machine's solids, the job's tool, holder, part and
fixture, the checked pairs and their clearances) and the verifier's own exact
distance (``machine_scene._distance``: fcl on the same objects), so a pose gets the
same distance in planning and in verification.

Cost: per pair, lower bounds for all poses at once - the bounding spheres'
``|c_i - c_j| - (r_i + r_j)`` and the gap of the two solids' vertices along the
direction the pair's last exact query found between its nearest points (turned with
solid ``i``; any direction gives a lower bound: ``min n.b - max n.a <= |b - a|``,
and the vertices' hulls hold the solids) - and fcl only where both are below the
pair's clearance plus ``cap``.
Along a sequence of poses (a path, a link) the exact distance ``d`` of a pair at one
pose bounds it at the next ones by ``d - motion`` (conservative advancement, the
motion bound ``|delta centre| + rho * delta angle`` of both solids as in the
verifier), so a pair far from its clearance is measured once per stretch.

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

from cam.verify.machine_scene import MachineScene, _distance, _radii
from postproc.machine_model import TOOL_SIDE, Solid, group_poses

__all__ = ["Clearances", "MachineClearance", "joint_path_samples"]

Array = NDArray[np.float64]
TOOL_SIDE_GROUPS = frozenset(TOOL_SIDE)
#: Rows whose witness gap is computed at once.
_GAP_BLOCK = 256


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
        self.support = [_hull_vertices(s) for s in scene.solids]
        self._first = np.array([i for i, _, _ in self.pairs], dtype=np.intp)
        self._second = np.array([j for _, j, _ in self.pairs], dtype=np.intp)
        self._reach = self.radius[self._first] + self.radius[self._second]
        self.witness: dict[int, Array] = {}  # pair -> direction in solid i's group frame
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
            centres = self._centres(poses)
            # every pair's bounding-sphere bound at once; only pairs below the limit
            # somewhere go on to the witness gaps, fcl and the advancement
            bound = np.linalg.norm(centres[:, self._first] - centres[:, self._second],
                                   axis=2) - self._reach
            distance[:] = np.maximum(bound, 0.0)
            close = np.flatnonzero((bound < (self.clearance + cap)[None, :]).any(axis=0))
            if close.size:
                moved = self._motion(joints, centres)
                for k in close.tolist():
                    distance[:, k], exact[:, k] = self._pair(poses, centres, moved, k, cap)
        self.poses += n
        self.seconds += time.process_time() - started
        return Clearances(distance, exact, self.clearance, self.names)

    def smallest(self, joints: Array, result: Clearances | None = None
                 ) -> tuple[float, tuple[str, str], int]:
        """The smallest exact distance of any checked pair over ``joints`` (n, 5).

        Returns ``(distance mm, pair names, row)``; ``(inf, ("", ""), -1)`` without
        poses or pairs. Poses whose lower bound is below the best distance found so
        far are measured until none is left. ``result``: this query's own
        ``query(joints)`` when the caller has it already (refined in place).
        """
        if result is None:
            result = self.query(joints)
        if not result.distance.size:
            return math.inf, ("", ""), -1
        started = time.process_time()
        distance, exact = result.distance, result.exact
        joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
        poses = None
        while True:
            known = np.where(exact, distance, math.inf)
            best = float(known.min())
            open_ = ~exact & (distance < best)
            if not math.isfinite(best):  # nothing measured: the smallest bound
                open_ = distance <= float(distance.min())
            if not open_.any():
                break
            if poses is None:
                poses = group_poses(self.kins, joints, self.scene.gauge, self.scene.tilt)
            for row, k in zip(*np.nonzero(open_), strict=True):
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

    def _centres(self, poses: dict[str, Any]) -> Array:
        """Bounding-sphere centres of every solid per pose ``(n, solids, 3)``."""
        return np.stack([poses[s.group][0] @ s.centre + poses[s.group][1]
                         for s in self.scene.solids], axis=1)

    def _motion(self, joints: Array, centres: Array) -> Array:
        """Motion bound of every solid from the row before ``(n, solids)``, mm."""
        n = len(joints)
        moved = np.zeros((n, len(self.scene.solids)))
        if n < 2:
            return moved
        turn = np.diff(joints[:, 3:], axis=0)
        turn = np.abs((turn + math.pi) % (2.0 * math.pi) - math.pi)  # the same rotation
        moved[1:] = np.linalg.norm(np.diff(centres, axis=0), axis=2)
        for k, solid in enumerate(self.scene.solids):
            if solid.group == self.scene.tilt:
                moved[1:, k] += solid.radius * turn[:, 0]
            elif solid.group == "C":
                moved[1:, k] += solid.radius * turn.sum(axis=1)
        return moved

    def _gap(self, poses: dict[str, Any], k: int, rows: NDArray[np.intp]) -> Array:
        """Gap of pair ``k``'s vertices along its witness direction at ``rows``, mm."""
        i, j, _ = self.pairs[k]
        a, b = self.scene.solids[i], self.scene.solids[j]
        out = np.empty(len(rows))
        for lo in range(0, len(rows), 2048):
            r = rows[lo:lo + 2048]
            n = poses[a.group][0][r] @ self.witness[k]  # (m, 3) machine frame
            proj = []
            for solid, verts in ((a, self.support[i]), (b, self.support[j])):
                rot, trans = poses[solid.group]
                local = np.einsum("mji,mj->mi", rot[r], n)
                proj.append((local @ verts.T, np.einsum("mi,mi->m", n, trans[r])))
            out[lo:lo + 2048] = (proj[1][0].min(axis=1) + proj[1][1]
                                 - proj[0][0].max(axis=1) - proj[0][1])
        return out

    def _exact(self, poses: dict[str, Any], k: int, s: int) -> float:
        """fcl distance of pair ``k`` at row ``s``; keeps its witness direction."""
        i, j, _ = self.pairs[k]
        points: list[Any] = []
        d = _distance(self.scene, poses, i, j, s, points)
        self.queries += 1
        if d > 1e-6 and len(points) == 2:
            n = np.asarray(points[1], np.float64) - np.asarray(points[0], np.float64)
            norm = float(np.linalg.norm(n))
            if norm > 1e-9:
                self.witness[k] = poses[self.scene.solids[i].group][0][s].T @ (n / norm)
        return d

    def _pair(self, poses: dict[str, Any], centres: Array, moved: Array, k: int,
              cap: float) -> tuple[Array, NDArray[np.bool_]]:
        """One pair over the sequence: distances (exact below ``limit``) and the mask.

        Rows are visited in order; at a row whose sphere bound is below the limit the
        witness gap (computed for the next ``_GAP_BLOCK`` such rows at once) is tried
        first, fcl only when it is below the limit too. A bound or distance ``d`` at a
        row skips the rows up to where the pair's motion since reaches ``d - limit``.
        """
        i, j, clearance = self.pairs[k]
        limit = clearance + cap
        bound = np.linalg.norm(centres[:, i] - centres[:, j], axis=1) \
            - (self.radius[i] + self.radius[j])
        cumulative = np.cumsum(moved[:, i] + moved[:, j])
        n = len(bound)
        exact = np.zeros(n, dtype=bool)
        value = np.maximum(bound, 0.0)
        need = np.flatnonzero(bound < limit)
        gap = np.full(n, -math.inf)
        gapped = np.zeros(n, dtype=bool)
        known_at: list[int] = []
        known: list[float] = []
        pos = 0
        while pos < len(need):
            s = int(need[pos])
            if k in self.witness and not gapped[s]:
                block = need[pos:pos + _GAP_BLOCK]
                gap[block] = self._gap(poses, k, block)
                gapped[block] = True
                value[block] = np.maximum(value[block], gap[block])
            nxt = s + 1
            if gap[s] >= limit:
                d = float(gap[s])  # a lower bound, not measured
                # and so are the gaps of the need rows after it, up to one below the limit
                tail = need[pos:]
                stop = np.flatnonzero(~gapped[tail] | (gap[tail] < limit))
                nxt = int(tail[stop[0]]) if stop.size else n
            else:
                d = self._exact(poses, k, s)
                exact[s] = True
                value[s] = d
            known_at.append(s)
            known.append(d)
            if d > limit:  # the pair cannot come within the limit before this row
                nxt = max(nxt, int(np.searchsorted(cumulative, cumulative[s] + (d - limit),
                                                   side="right")))
            pos = int(np.searchsorted(need, nxt, side="left"))
        if known_at:
            # rows after a known one (and not measured): d - motion is a bound too
            at = np.asarray(known_at)
            last = np.full(n, -1)
            last[at] = at
            last = np.maximum.accumulate(last)
            has = (last >= 0) & ~exact
            d_last = np.zeros(n)
            d_last[at] = known
            carried = d_last[np.maximum(last, 0)] - (cumulative - cumulative[np.maximum(last, 0)])
            value = np.where(has, np.maximum(value, carried), value)
        return value, exact


def _hull_vertices(solid: Solid) -> Array:
    """Vertices of the convex hull of a solid's points (its support function's)."""
    import trimesh

    points = np.vstack(solid.pieces) if solid.pieces else solid.vertices
    if len(points) <= 8:
        return np.asarray(points, np.float64)
    return np.asarray(trimesh.convex.convex_hull(points).vertices, np.float64)


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
