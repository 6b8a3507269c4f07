"""Checks of a roughing plan: collisions of postures, moves and index moves, and the
smallest allowance the ball keeps from the design (rough.json's check fields)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.collision import CollisionScene
from cam.roughing.plan import Segment
from postproc.toolpath import MoveKind

if TYPE_CHECKING:
    from cam.roughing.command import RoughResult

__all__ = ["CONTACT_MARGIN", "check_collisions", "min_allowance"]

#: The drop-cutter leaves the ball exactly eta from the design triangles, and the
#: collision service's tool meshes circumscribe the tool by up to ~0.05 mm: the
#: cutter is checked grown by ``eta - CONTACT_MARGIN`` so a tangent ball is not a hit.
CONTACT_MARGIN = 0.05

def _index_poses(kins: Any, a: Segment, b: Segment, samples: int = 24
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poses along the index move from the end of ``a`` to the start of ``b``.

    The machine moves its joints on a straight line (a synchronised rapid), so the
    tool sweeps the forward kinematics of the interpolated joints, not a line in W.
    """
    q = np.asarray(kins.inverse(np.stack([a.tip[-1], b.tip[0]]),
                                np.stack([a.axis[-1], b.axis[0]])))
    t = np.linspace(0.0, 1.0, samples)[:, None]
    tip, axis = kins.forward(q[0][None] + t * (q[1] - q[0])[None])
    return np.asarray(tip), np.asarray(axis)


def check_collisions(scene: CollisionScene, result: RoughResult, eta: float,
                     kins: Any = None) -> dict[str, Any]:
    """Postures, all moves and index moves of the 3+2 plan; the baseline's moves.

    * every posture of every passage: the cutter grown by ``eta - CONTACT_MARGIN``
      and shank/holder closer than eta count as hits;
    * every move (cutting, link, retract) of passage 0's segments by subdivision
      (``check_motion``, 1 mm / 1 deg); the other passages are rotations of them by
      the blade pitch, and their postures are all checked above;
    * every index move between segments along the machine's joint-space path
      (forward kinematics of the interpolated joints), when ``kins`` is given;
    * the five-axis baseline's moves of passage 0 the same way (reported, not part
      of ``collisions``).

    Returns
    -------
    dict
        ``collisions`` (3+2 hits), ``postures_checked``, ``moves_checked``,
        ``index_moves_checked``, ``min_clearance_mm`` (shank+holder, capped at
        max(eta, 1)), ``hits`` (list of {kind, umr, part, role}) and
        ``baseline_collisions`` / ``baseline_moves_checked``.
    """
    grown = -(eta - CONTACT_MARGIN)
    cap = max(eta, 1.0)
    parts = ("cutter", "shank", "holder")
    hits: list[dict[str, Any]] = []

    def note(report: Any, what: str, umr: int) -> int:
        bad = np.flatnonzero(report.blocked(eta))
        for i in bad[:20].tolist():
            part = int(report.part[i])
            hits.append({"check": what, "umr": umr, "role": report.hit_role[i],
                         "part": parts[part] if part >= 0 else "clearance < eta"})
        return int(len(bad))

    segs = result.segments
    tips = np.concatenate([s.tip for s in segs])
    axes = np.concatenate([s.axis for s in segs])
    posture = scene.check_postures(result.tool, tips, axes, cutter_allowance=grown,
                                   clearance_cap=cap)
    bad = note(posture, "posture", -1)
    clear = float(np.nanmin(posture.clearance)) if len(posture.clearance) else np.inf
    moves = 0
    for s in segs:
        if s.passage != 0 or len(s.tip) < 2:
            continue
        motion = scene.check_motion(result.tool, s.tip, s.axis, max_step_mm=1.0,
                                    max_step_deg=1.0, cutter_allowance=grown,
                                    clearance_cap=cap)
        bad += note(motion, "move", s.umr + 1)
        moves += len(s.tip) - 1
    index_moves = 0
    if kins is not None:
        for a, b in zip(segs[:-1], segs[1:], strict=True):
            tip, axis = _index_poses(kins, a, b)
            report = scene.check_postures(result.tool, tip, axis, cutter_allowance=grown,
                                          clearance_cap=cap)
            bad += note(report, "index", b.umr + 1)
            index_moves += 1
    base_bad = 0
    base_moves = 0
    for base in result.baseline:
        if base.passage != 0:
            continue
        base_report = scene.check_motion(result.tool, base.tip, base.axis, max_step_mm=1.0,
                                         max_step_deg=1.0, cutter_allowance=grown,
                                         clearance_cap=cap)
        base_bad += int(base_report.blocked(eta).sum())
        base_moves += len(base.tip) - 1
    return {"collisions": bad, "postures_checked": len(tips), "moves_checked": moves,
            "index_moves_checked": index_moves, "min_clearance_mm": clear, "hits": hits,
            "baseline_collisions": base_bad, "baseline_moves_checked": base_moves}


def min_allowance(result: RoughResult, segments: list[Segment] | None = None) -> float:
    """Smallest distance of the ball surface from the design triangles, mm.

    Exact point-triangle distances (``cam.collision.triangle_bvh``) of the ball
    centres of passage 0 (the other passages are rotations of it), at the poses and
    at 3 points inside every cutting move, of ``segments`` (default: the 3+2 plan).
    """
    from cam.collision.triangle_bvh import TriangleBVH

    radius = result.tool.radius
    centres = []
    for s in result.segments if segments is None else segments:
        if s.passage != 0:
            continue
        c = s.tip + radius * s.axis
        cut = (s.kind[1:] == MoveKind.FEED) | (s.kind[1:] == MoveKind.PLUNGE)
        a, b = c[:-1][cut], c[1:][cut]
        t = np.arange(1, 4)[:, None, None] / 4.0
        centres += [c, (a[None] + t * (b - a)[None]).reshape(-1, 3)]
    if not centres:
        return float("nan")
    points = np.concatenate(centres)
    bvh = TriangleBVH(np.concatenate([np.asarray(m.triangles) for m in result.meshes.values()]))
    d = bvh.distances(points, 4.0 * radius)
    return float(d.min() - radius)
