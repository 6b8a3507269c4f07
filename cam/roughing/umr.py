"""Unit Machining Regions (M4, Figs. 2-4): fixed cutter axes that cover a passage.

Partition (our implementation of the flowchart of Fig. 4):

1. The first candidate axis is the ruling of the suction surface at its shroud point
   ``P_1`` at the region start, pointing from the hub to the shroud (tip towards
   spindle). On our fixtures that axis alone leaves most of the passage width in the
   shadow of the pressure blade, so a few more rulings are tried as candidates (the
   pressure-side and mid-passage rulings at and a little ahead of the start) and the
   one whose region reaches furthest is kept.
2. Rotate the scene by alpha about X and beta about Y so the axis is +Z
   (``dropcutter.frame_to_z``) and project onto the x-y plane. The paper reads the
   interference-free region off the projected hub and shroud curves; we decide it
   with the tool's size: a hub-floor target is *reached* when the ball (radius
   R + eta) dropped along the axis onto hub, blades and splitters stops within
   ``reach_tolerance`` of it. A station (a cross-section of the passage) belongs to
   the region while the reached share of its floor area is at least ``min_reach``.
3. Where that stops (the point P2 where the neighbouring blade's shroud curve starts
   to hide the hub curve), the next UMR starts with the ruling there as its axis.
4. Repeat until the trailing edge. Each UMR's A and C come from the machine's inverse
   kinematics of its axis (passage 0; passage k adds ``k * pitch`` to C).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from cam.roughing.dropcutter import DropCutter, frame_to_z
from cam.roughing.passage import PassageGrid
from cam.tools import Tool
from geometry.surfaces import BladeSurface
from impeller_cam.errors import InputError

__all__ = ["UMR", "FixedAxisFrame", "partition_passage", "reached_floor"]

#: Default look-ahead fractions of the candidate axes (see ``partition_passage``).
LOOK_AHEAD = (0.0, 0.1, 0.2)
#: The shank keeps this much clearance beyond the stock roughing leaves on the walls
#: (eta + scallop), mm: verify found nine_blade's ball10 shank (just above its 22 mm
#: flutes) 0.6-0.75 mm from the blades near their tips in the deepest layers, in
#: that stock (99 shank events, up to 3.2 mm deep).
SHANK_MARGIN = 0.25
#: Turns (deg) of the candidate axes towards the impeller axis (+Z) tried when no
#: candidate's orientation keeps the machine clear (``partition_passage``).
TOWARDS_Z_DEG = (5.0, 10.0, 15.0, 20.0, 30.0, 40.0)

#: ``admissible(axis, centres) -> (clear, why)``: the machine keeps clear of an
#: orientation at those ball-centre targets (``cam.roughing.machine_pose``).
Admissible = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[bool, str]]


class FixedAxisFrame:
    """The scene turned so that a fixed cutter axis is +Z, with its drop-cutter.

    Parameters
    ----------
    axis : (3,) float64
        Unit cutter axis in W (tip towards spindle).
    triangles : (m, 3, 3) float64
        Design triangles in W (hub, blades, splitters), mm.
    rho : float
        Ball radius plus allowance, mm.
    """

    def __init__(self, axis: NDArray[np.float64], triangles: NDArray[np.float64],
                 rho: float) -> None:
        self.axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
        self.matrix, self.alpha, self.beta = frame_to_z(self.axis)
        self.triangles = triangles @ self.matrix.T
        self.rho = float(rho)
        self.cutter = DropCutter(self.triangles, self.rho)
        self.top = float(self.triangles[:, :, 2].max())
        self.shank: tuple[float, DropCutter] | None = None
        #: what the links drop onto: ``cut_floor`` behind a drop-cutter's interface
        self.tool = _ToolDrop(self)

    def keep_shank_clear(self, tool: Tool, stock: float) -> None:
        """Also keep the tool's shank ``stock + SHANK_MARGIN`` mm from the design
        (``stock``: what roughing leaves on the walls, eta + scallop): ``cut_floor``
        then holds the ball centre so that a ball of the shank's radius plus that,
        centred where the flutes end, touches nothing; what that ball sweeps on its
        way down contains the shank cylinder above it (and the top of the flutes)."""
        shank = max([tool.radius, *(max(s.r0, s.r1) for s in tool.shank_segments())])
        self.shank = (tool.flute_length - tool.radius,
                      DropCutter(self.triangles, shank + stock + SHANK_MARGIN))

    def cut_floor(self, local: NDArray[np.float64]) -> NDArray[np.float64]:
        """Lowest ball-centre heights ``(n,)`` (frame z) under frame points ``(n, 3)``:
        the ball's drop, and with ``keep_shank_clear`` the shank's."""
        floor = self.cutter.drop(local)
        if self.shank is not None:
            offset, shank = self.shank
            floor = np.maximum(floor, shank.drop(local) - offset)
        return np.asarray(floor)

    def to_frame(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """W points ``(..., 3)`` -> frame coordinates."""
        return np.asarray(points @ self.matrix.T)

    def to_world(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Frame points ``(..., 3)`` -> W."""
        return np.asarray(points @ self.matrix)

    def drop(self, points_w: NDArray[np.float64]) -> NDArray[np.float64]:
        """Drop-cutter ball-centre heights (frame z) under W points ``(..., 3)``."""
        local = self.to_frame(points_w)
        flat = local.reshape(-1, 3)
        return np.asarray(self.cutter.drop(flat).reshape(local.shape[:-1]))


class _ToolDrop:
    """``drop(points)`` of a frame's whole tool (ball and, if kept clear, shank)."""

    def __init__(self, frame: FixedAxisFrame) -> None:
        self.frame = frame

    def drop(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.frame.cut_floor(points)


@dataclass
class UMR:
    """One unit machining region of passage 0.

    Attributes
    ----------
    index : int
        0-based order.
    stations : (2,) int
        First and last station index (inclusive) of the region.
    u_range : (2,) float
        Camber parameters of those stations.
    axis : (3,) float64
        Fixed cutter axis in W for passage 0.
    alpha, beta : float
        Rotations about X and Y taking the axis onto +Z, rad.
    reached : (n_s + 1, m) bool
        Hub targets the axis reaches (whole passage).
    area : float
        Hub floor area the region covers (reached targets of its stations), mm^2.
    joints : (5,) float64
        X, Y, Z, A, C of the region's first tool pose (passage 0), mm and rad.
    lane : int
        The lane of passage 0 it cuts (``passage.passage_lanes``).
    """

    index: int
    stations: tuple[int, int]
    u_range: tuple[float, float]
    axis: NDArray[np.float64]
    alpha: float
    beta: float
    reached: NDArray[np.bool_]
    area: float
    frame: FixedAxisFrame
    joints: NDArray[np.float64] = field(default_factory=lambda: np.full(5, np.nan))
    lane: int = 0


def reached_floor(frame: FixedAxisFrame, grid: PassageGrid,
                  tolerance: float) -> NDArray[np.bool_]:
    """Hub targets ``(n_s + 1, m)`` the frame's drop reaches within ``tolerance`` mm."""
    hub = grid.centres[-1]
    target_z = frame.to_frame(hub)[..., 2]
    return np.asarray(frame.drop(hub) <= target_z + tolerance)


def _extent(share: NDArray[np.float64], start: int, min_reach: float) -> int:
    stop = start
    while stop < len(share) and share[stop] >= min_reach:
        stop += 1
    return stop


def towards_z(axis: NDArray[np.float64], degrees: float) -> NDArray[np.float64]:
    """The unit ``axis`` (3,) turned ``degrees`` towards +Z (at most onto it)."""
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    tilt = float(np.arccos(np.clip(a[2], -1.0, 1.0)))
    turn = min(np.radians(degrees), tilt)
    side = a - a[2] * np.array([0.0, 0.0, 1.0])
    norm = float(np.linalg.norm(side))
    if norm < 1e-12:
        return a
    new_tilt = tilt - turn
    return np.asarray(np.sin(new_tilt) * side / norm + np.array([0.0, 0.0, np.cos(new_tilt)]))


def partition_passage(grid: PassageGrid, suction_blade: BladeSurface,
                      triangles: NDArray[np.float64], rho: float, *,
                      reach_tolerance: float, min_reach: float,
                      look_ahead: tuple[float, ...] = LOOK_AHEAD, first_index: int = 0,
                      lane: int = 0, admissible: Admissible | None = None) -> list[UMR]:
    """UMRs of passage 0 from leading to trailing edge (see module docstring).

    Parameters
    ----------
    grid : PassageGrid
    suction_blade : BladeSurface
        The blade whose suction side bounds the passage (its rulings give the
        first candidate axis of each region).
    triangles : (m, 3, 3) float64
        Design triangles near the passage, W, mm.
    rho : float
        R + eta, mm.
    reach_tolerance : float
        A hub target is reached when the dropped ball centre is at most this much
        above it, mm.
    min_reach : float
        Smallest reached share of a station's floor area for the station to join
        the region (0..1).
    look_ahead : tuple of float
        Candidate axes: besides the suction-side ruling at the region start, the
        pressure-side and mid-passage rulings at these fractions of the passage
        length ahead of the start. The candidate that extends the region furthest
        wins (ties: the earlier candidate).
    first_index, lane : int
        Index of the first UMR returned, and the lane (``passage_lanes``) they cut.
    admissible : callable, optional
        ``admissible(axis, centres)``: whether the machine keeps clear of the
        orientation at the region's ball-centre targets ``(k, 3)``
        (``machine_pose.region_targets``). Candidates are tried best first; when
        none is admissible, the candidates turned ``TOWARDS_Z_DEG`` towards the
        impeller axis are tried (the reach check decides what they cover).

    Raises
    ------
    InputError
        No candidate orientation of a region keeps the machine clear.
    """
    m = len(grid.u)
    area = grid.floor_area
    mid = grid.n_s // 2
    umrs: list[UMR] = []
    start = 0
    while start < m:
        own = (grid.u[start] - suction_blade.u_start) / (1.0 - suction_blade.u_start)
        candidates = [-np.asarray(suction_blade.ruling(float(np.clip(own, 0.0, 1.0))))]
        for ahead in look_ahead:
            i = min(m - 1, start + int(round(ahead * (m - 1))))
            candidates += [grid.ruling[0, i], grid.ruling[mid, i]]
        chosen = _choose(candidates, grid, triangles, rho, reach_tolerance, min_reach,
                         start, admissible)
        if chosen is None:
            assert admissible is not None
            turned = [towards_z(a, t) for t in TOWARDS_Z_DEG for a in candidates]
            chosen = _choose(turned, grid, triangles, rho, reach_tolerance, min_reach,
                             start, admissible)
        if chosen is None:
            assert admissible is not None
            _, why = admissible(candidates[0], _targets(grid, start, start + 1))
            raise InputError(
                f"no orientation of the UMR starting at station {start} (lane {lane}, "
                f"u = {grid.u[start]:.3f}) keeps the machine clear: {why}",
                field="machine", value=f"{len(candidates) * (1 + len(TOWARDS_Z_DEG))} "
                "orientations tried", accepted="a machine that reaches the passage with "
                "every component clear (another machine, a riser, a longer tool)")
        best, frame, reached = chosen
        stop = max(best[0], start + 1)  # an axis that serves no station still takes one
        covered = float((reached[:, start:stop] * area[:, start:stop]).sum())
        prev = umrs[-1] if umrs else None
        if prev is not None and np.allclose(prev.axis, frame.axis, atol=1e-12):
            # the same axis again (a station no candidate serves): extend the region
            prev.stations = (prev.stations[0], stop - 1)
            prev.u_range = (prev.u_range[0], float(grid.u[stop - 1]))
            prev.area += covered
            start = stop
            continue
        umrs.append(UMR(first_index + len(umrs), (start, stop - 1),
                        (float(grid.u[start]), float(grid.u[stop - 1])),
                        frame.axis, frame.alpha, frame.beta, reached, covered, frame,
                        lane=lane))
        start = stop
    return umrs


def _targets(grid: PassageGrid, start: int, stop: int) -> NDArray[np.float64]:
    from cam.roughing.machine_pose import region_targets

    return region_targets(grid.centres, start, stop)


def _choose(candidates: list[NDArray[np.float64]], grid: PassageGrid,
            triangles: NDArray[np.float64], rho: float, reach_tolerance: float,
            min_reach: float, start: int, admissible: Admissible | None
            ) -> tuple[tuple[int, float], FixedAxisFrame, NDArray[np.bool_]] | None:
    """The candidate whose region reaches furthest (ties: the earlier) among those
    ``admissible`` over that region; its score, frame and reached targets."""
    area = grid.floor_area
    scored = []
    for order, axis in enumerate(candidates):
        frame = FixedAxisFrame(axis, triangles, rho)
        reached = reached_floor(frame, grid, reach_tolerance)
        share = (reached * area).sum(axis=0) / np.maximum(area.sum(axis=0), 1e-300)
        stop = _extent(share, start, min_reach)
        scored.append(((stop, float(share[start])), -order, frame, reached))
    scored.sort(key=lambda item: (item[0], item[1]), reverse=True)
    for score, _, frame, reached in scored:
        if admissible is None or admissible(
                frame.axis, _targets(grid, start, max(score[0], start + 1)))[0]:
            return score, frame, reached
    return None
