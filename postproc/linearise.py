"""Rotary linearisation: split simultaneous moves until the tool follows the CL segment.

A controller interpolates the joints of a block linearly (joint mode) or the tip in
the workpiece frame and the rotary joints linearly (TCP mode). Between two APT
records the tool then leaves the straight CL segment: in joint mode the tip bows
away from it, in both modes the tool axis leaves the great circle between the two
records' axes. ``linearise`` inserts intermediate CL poses (tip on the segment, axis
on the great circle) until every block keeps

* the tip within ``chordal`` of the CL segment (joint mode; exact in TCP mode), and
* the tool axis within ``angular`` of the great-circle arc.

It works on all segments at once: evaluate every open piece at ``SAMPLES`` interior
joint-space points, accept the pieces that pass, halve the others, repeat. No Python
loop runs per point; the loop runs per refinement level.

Sampling bound. Along a block the joints are ``q(t) = q0 + t (q1 - q0)``, 0 <= t <= 1.
For a table-tilting machine the tip is ``tip(t) = Rc(t) (Ru(t) (J(t) - r - o) + o)``
with rotations linear in t (see postproc.kinematics.trt), so
``|tip''| <= w^2 rho + 2 w |dJ| =: M`` with ``w = |dA| + |dC|`` (rad),
``dJ`` the linear joint step and ``rho >= |J - r - o| + |o|``. The distance to the
(convex) CL segment is a convex function of the point, and the chord between two
samples ``h`` apart is within ``h^2 M / 8`` of the curve, so the true largest
deviation is at most the sampled largest deviation plus ``h^2 M / 8``;
``h = 1 / (SAMPLES + 1)``. A piece is accepted only when this bound is within the
tolerance (for the axis the same bound with ``|axis''| <= w^2``, to first order in
the angle). Kinematics without ``rot_point``/``offset`` attributes get ``rho`` from a
second finite difference of the sampled tips, doubled.

Near a singular pose (tool axis on the C axis) a CL split cannot shrink a C swing;
a piece whose CL length falls below ``MIN_PIECE`` is split in joint space instead
(rotary joints halved, tip held on the CL point). A piece that still fails after
``MAX_LEVELS`` halvings, or a segment with more than ``MAX_OPEN`` pieces still
failing (a C re-wind or a branch change inside a feed move), is an ``InputError``
naming the APT record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from postproc.kinematics.base import Kinematics

#: Interior joint-space samples per piece and refinement level.
SAMPLES = 7
#: CL-parameter length below which a failing piece is split in joint space.
MIN_PIECE = 1e-9
#: Largest number of halvings of one segment.
MAX_LEVELS = 60
#: Largest number of pieces of one segment still failing at one level.
MAX_OPEN = 4096
#: Segments processed together (bounds memory: about 1 kB per segment and level).
CHUNK = 32768
_FULL = np.int64(2) ** MAX_LEVELS


@dataclass
class Linearised:
    """The blocks of a linearised path, in order.

    Attributes
    ----------
    joints : (m, 5) float64
        Joints at the end of each block.
    tip : (m, 3) float64
        CL tip at the end of each block (on the CL segment), W, mm.
    axis : (m, 3) float64
        CL tool axis at the end of each block, unit.
    segment : (m,) int64
        Index ``i`` of the CL segment (pose ``i - 1`` to pose ``i``) the block belongs to.
    inserted : (m,) bool
        True for blocks added by the linearisation (False: the block ends on pose i).
    tip_length : (m,) float64
        Length of the tip path of the block in W, mm (sampled chords in joint mode).
    """

    joints: NDArray[np.float64]
    tip: NDArray[np.float64]
    axis: NDArray[np.float64]
    segment: NDArray[np.int64]
    inserted: NDArray[np.bool_]
    tip_length: NDArray[np.float64]


def slerp(a0: NDArray[np.float64], a1: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray:
    """Great-circle interpolation of unit vectors.

    Parameters
    ----------
    a0, a1 : (n, 3) float64
        Unit vectors (not antipodal).
    u : (n,) float64
        Parameters in [0, 1].

    Returns
    -------
    (n, 3) float64
        Unit vectors; a linear blend normalised where ``a0`` and ``a1`` nearly coincide.
    """
    dot = np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0)
    omega = np.arccos(dot)
    small = omega < 1e-6
    sin_omega = np.where(small, 1.0, np.sin(omega))
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * omega) / sin_omega)
    w1 = np.where(small, u, np.sin(u * omega) / sin_omega)
    out = w0[:, None] * a0 + w1[:, None] * a1
    return out / np.linalg.norm(out, axis=1)[:, None]


def segment_distance(
    points: NDArray[np.float64], s0: NDArray[np.float64], s1: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance of points to line segments, mm.

    Parameters
    ----------
    points : (n, k, 3) float64
        k points per segment.
    s0, s1 : (n, 3) float64
        Segment ends.

    Returns
    -------
    (n, k) float64
    """
    d = s1 - s0
    length2 = np.einsum("ij,ij->i", d, d)
    rel = points - s0[:, None, :]
    t = np.einsum("ikj,ij->ik", rel, d) / np.where(length2 > 0.0, length2, 1.0)[:, None]
    t = np.clip(np.where(length2[:, None] > 0.0, t, 0.0), 0.0, 1.0)
    foot = s0[:, None, :] + t[..., None] * d[:, None, :]
    return np.linalg.norm(points - foot, axis=2)


def arc_distance(
    vectors: NDArray[np.float64], a0: NDArray[np.float64], a1: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Angle from unit vectors to the shorter great-circle arc between a0 and a1, rad.

    Parameters
    ----------
    vectors : (n, k, 3) float64
        k unit vectors per arc.
    a0, a1 : (n, 3) float64
        Arc ends (unit).

    Returns
    -------
    (n, k) float64
    """
    normal = np.cross(a0, a1)
    norm = np.linalg.norm(normal, axis=1)
    degenerate = norm < 1e-12
    normal = normal / np.where(degenerate, 1.0, norm)[:, None]
    off_plane = np.einsum("ikj,ij->ik", vectors, normal)
    in_plane = vectors - off_plane[..., None] * normal[:, None, :]
    # inside the arc: in-plane part lies between a0 and a1 (same side of both ends)
    side0 = np.einsum("ikj,ij->ik", np.cross(a0[:, None, :], in_plane), normal)
    side1 = np.einsum("ikj,ij->ik", np.cross(in_plane, a1[:, None, :]), normal)
    inside = (side0 >= 0.0) & (side1 >= 0.0) & ~degenerate[:, None]
    to_plane = np.arcsin(np.clip(np.abs(off_plane), 0.0, 1.0))
    to_ends = np.minimum(_angle(vectors, a0[:, None, :]), _angle(vectors, a1[:, None, :]))
    return np.where(inside, to_plane, to_ends)


def _axis_within(
    vectors: NDArray[np.float64], a0: NDArray[np.float64], a1: NDArray[np.float64],
    limit: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Per row: all k vectors within ``limit`` (rad) of the arc a0-a1.

    The angle to the nearer arc end bounds the angle to the arc from above, so rows
    passing that cheap test skip ``arc_distance``.
    """
    cos_limit = np.cos(np.clip(limit, 0.0, np.pi))[:, None]
    near_end = np.maximum(np.einsum("ikj,ij->ik", vectors, a0),
                          np.einsum("ikj,ij->ik", vectors, a1))
    ok = (limit >= 0.0) & np.all(near_end >= cos_limit, axis=1)
    rest = ~ok & (limit >= 0.0)
    if rest.any():
        ok[rest] = arc_distance(vectors[rest], a0[rest], a1[rest]).max(axis=1) <= limit[rest]
    return ok


def _angle(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle between unit vectors (robust for small angles), rad."""
    return 2.0 * np.arctan2(np.linalg.norm(u - v, axis=-1), np.linalg.norm(u + v, axis=-1))


def joints_near(
    kins: Kinematics,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    reference: NDArray[np.float64],
    singular_tilt: float,
) -> NDArray[np.float64]:
    """Joints reaching each pose on the branch and C winding nearest ``reference``.

    Parameters
    ----------
    kins : Kinematics
    tip, axis : (n, 3) float64
        Poses in W.
    reference : (n, 5) float64
        Joints to stay close to (rotary distance ``|dA| + |dC|``).
    singular_tilt : float
        Tilt (rad) below which C is undefined; there C is taken from ``reference``.

    Returns
    -------
    (n, 5) float64
        X, Y, Z solved through the forward kinematics for the chosen rotary joints
        (tool length 0), so singular poses keep the tip exact.
    """
    branches = kins.inverse_branches(tip, axis)  # (2, n, 5), C in (-pi, pi]
    two_pi = 2.0 * np.pi
    c = branches[:, :, 4]
    c = c + two_pi * np.round((reference[None, :, 4] - c) / two_pi)
    cost = np.abs(branches[:, :, 3] - reference[None, :, 3]) + np.abs(c - reference[None, :, 4])
    pick = (cost[1] < cost[0]).astype(np.int64)
    rows = np.arange(len(tip))
    rotary = np.stack([branches[pick, rows, 3], c[pick, rows]], axis=1)
    singular = np.abs(rotary[:, 0]) < singular_tilt
    rotary[singular, 1] = reference[singular, 4]
    return np.hstack([linear_joints(kins, tip, rotary), rotary])


def linear_joints(
    kins: Kinematics, tip: NDArray[np.float64], rotary: NDArray[np.float64]
) -> NDArray[np.float64]:
    """X, Y, Z putting the tip at ``tip`` (W) for given rotary joints, (n, 3) mm.

    The forward kinematics is affine in X, Y, Z for fixed rotary joints,
    ``tip = R q + b``, with R a rotation; so ``q = R^T (tip - b)`` from four forward
    evaluations. Works for any registered kinematics.
    """
    n = len(tip)
    base = np.zeros((4 * n, 5))
    base[:, 3:] = np.tile(rotary, (4, 1))
    for k in range(3):
        base[(k + 1) * n : (k + 2) * n, k] = 1.0
    image, _ = kins.forward(base)
    b = image[:n]
    columns = np.stack([image[(k + 1) * n : (k + 2) * n] - b for k in range(3)], axis=2)
    return np.einsum("nji,nj->ni", columns, tip - b)


def _lever(kins: Kinematics, joints: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """``rho = |J - r - o| + |o|`` per row for table-tilting kinematics, else None."""
    rot_point = getattr(kins, "rot_point", None)
    offset = getattr(kins, "offset", None)
    if rot_point is None or offset is None:
        return None
    offset = np.asarray(offset, dtype=np.float64)
    rel = joints[..., :3] - np.asarray(rot_point, dtype=np.float64) - offset
    return np.linalg.norm(rel, axis=-1) + float(np.linalg.norm(offset))


def lever_bound(kins: Kinematics, joints: NDArray[np.float64]) -> float:
    """Largest lever ``rho`` (mm) over ``joints``: how far rotary steps move the tip."""
    if len(joints) == 0:
        return 0.0
    lever = _lever(kins, joints)
    if lever is None:
        tip, _ = kins.forward(joints)
        return float(np.max(np.linalg.norm(tip, axis=1))) + float(
            np.max(np.linalg.norm(joints[:, :3], axis=1))
        )
    return float(np.max(lever))


def linearise(
    kins: Kinematics,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    joints: NDArray[np.float64],
    check: NDArray[np.bool_],
    chordal: float,
    angular: float,
    *,
    tcp: bool = False,
    singular_tilt: float = 1e-9,
    records: NDArray[np.int64] | None = None,
    where: str = "",
) -> Linearised:
    """Split the checked segments of a pose sequence into blocks within tolerance.

    Parameters
    ----------
    kins : Kinematics
        Forward and inverse kinematics (tool length 0: joints command the tip).
    tip, axis : (n, 3) float64
        CL poses in W.
    joints : (n, 5) float64
        Joints of the poses (continuous branch, from ``kins.inverse``).
    check : (n,) bool
        ``check[i]``: segment ``i`` (pose i-1 to i) is a simultaneous feed move to be
        linearised; ``check[0]`` is ignored. Unchecked segments become one block.
    chordal : float
        Tip tolerance, mm (joint mode only; TCP keeps the tip on the segment).
    angular : float
        Tool-axis tolerance, rad.
    tcp : bool
        The controller interpolates the tip in W (tool-centre-point control).
    singular_tilt : float
        Tilt below which C is undefined, rad.
    records : (n,) int64, optional
        APT record of each pose, for error messages.
    where : str
        What the poses are (file, operation), for error messages.

    Returns
    -------
    Linearised
        Blocks for segments 1..n-1 in order (pose 0 itself is not a block).

    Raises
    ------
    InputError
        When a segment cannot be brought within tolerance (see module docstring).
    """
    tip = np.asarray(tip, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    joints = np.asarray(joints, dtype=np.float64)
    n = len(tip)
    if n - 1 > CHUNK:
        parts = []
        for start in range(0, n - 1, CHUNK):
            stop = min(start + CHUNK + 1, n)
            part = linearise(kins, tip[start:stop], axis[start:stop], joints[start:stop],
                             np.asarray(check)[start:stop], chordal, angular, tcp=tcp,
                             singular_tilt=singular_tilt,
                             records=None if records is None else records[start:stop],
                             where=where)
            part.segment += start
            parts.append(part)
        return Linearised(*(np.concatenate([getattr(p, f) for p in parts])
                            for f in Linearised.__dataclass_fields__))
    if n < 2:
        empty = np.zeros((0, 3))
        return Linearised(np.zeros((0, 5)), empty, empty, np.zeros(0, np.int64),
                          np.zeros(0, bool), np.zeros(0))
    seg_all = np.arange(1, n, dtype=np.int64)
    checked = np.asarray(check, dtype=bool)[1:]
    # accepted pieces: segment, u_end, joints_end, tip length
    done_seg = [seg_all[~checked]]
    done_key = [np.full(int((~checked).sum()), _FULL, dtype=np.int64)]
    done_q = [joints[1:][~checked]]
    done_len = [np.linalg.norm(tip[1:][~checked] - tip[:-1][~checked], axis=1)]
    seg = seg_all[checked]
    k0 = np.zeros(len(seg), dtype=np.int64)  # piece ends as exact dyadic keys:
    k1 = np.full(len(seg), _FULL, dtype=np.int64)  # u = key / 2**MAX_LEVELS
    q0 = joints[seg - 1]
    q1 = joints[seg]
    # Whole segments begin and end exactly on their CL poses (deviation 0 there), so
    # the sampling bound with h = 1 accepts them unsampled when M / 8 fits the tolerance.
    lever = _lever(kins, np.stack([q0, q1], axis=1))
    if lever is not None and len(seg):
        dq = q1 - q0
        w = np.abs(dq[:, 3]) + np.abs(dq[:, 4])
        step = np.sqrt(np.einsum("ij,ij->i", dq[:, :3], dq[:, :3]))
        bound = w * w * (lever.max(axis=1) + step) + 2.0 * w * step
        quick = (w * w / 8.0 <= angular) & (tcp | (bound / 8.0 <= chordal))
        chord = tip[seg[quick]] - tip[seg[quick] - 1]
        done_seg.append(seg[quick])
        done_key.append(k1[quick])
        done_q.append(q1[quick])
        done_len.append(np.sqrt(np.einsum("ij,ij->i", chord, chord)))
        seg, k0, k1, q0, q1 = seg[~quick], k0[~quick], k1[~quick], q0[~quick], q1[~quick]
    h = 1.0 / (SAMPLES + 1)
    t = np.arange(1, SAMPLES + 1) * h
    for _level in range(MAX_LEVELS + 1):
        if len(seg) == 0:
            break
        u0, u1 = k0 / _FULL, k1 / _FULL
        dq = q1 - q0
        samples = q0[:, None, :] + t[None, :, None] * dq[:, None, :]
        flat = samples.reshape(-1, 5)
        s_tip, s_axis = kins.forward(flat)
        s_tip = s_tip.reshape(len(seg), SAMPLES, 3)
        s_axis = s_axis.reshape(len(seg), SAMPLES, 3)
        w = np.abs(dq[:, 3]) + np.abs(dq[:, 4])
        axis_ok = _axis_within(s_axis, axis[seg - 1], axis[seg], angular - h * h / 8.0 * w * w)
        p_start = tip[seg - 1] + u0[:, None] * (tip[seg] - tip[seg - 1])
        p_end = tip[seg - 1] + u1[:, None] * (tip[seg] - tip[seg - 1])
        if tcp:
            tip_ok = np.ones(len(seg), dtype=bool)
            length = np.linalg.norm(p_end - p_start, axis=1)
        else:
            tip_dev = segment_distance(s_tip, tip[seg - 1], tip[seg]).max(axis=1)
            lever = _lever(kins, np.stack([q0, q1], axis=1))
            if lever is None:
                curve = np.concatenate([p_start[:, None], s_tip, p_end[:, None]], axis=1)
                second = np.linalg.norm(np.diff(curve, n=2, axis=1), axis=2).max(axis=1)
                bound = 2.0 * second / (h * h)
            else:
                step = np.linalg.norm(dq[:, :3], axis=1)
                rho = lever.max(axis=1) + step
                bound = w * w * rho + 2.0 * w * step
            tip_ok = tip_dev + h * h / 8.0 * bound <= chordal
            curve = np.concatenate([p_start[:, None], s_tip, p_end[:, None]], axis=1)
            length = np.linalg.norm(np.diff(curve, axis=1), axis=2).sum(axis=1)
        ok = tip_ok & axis_ok
        done_seg.append(seg[ok])
        done_key.append(k1[ok])
        done_q.append(q1[ok])
        done_len.append(length[ok])
        bad = ~ok
        if not bad.any():
            seg = seg[:0]
            break
        open_count = np.bincount(seg[bad])
        if _level == MAX_LEVELS or open_count.max() > MAX_OPEN:
            seg = seg[bad][np.isin(seg[bad], np.flatnonzero(open_count > MAX_OPEN))] \
                if open_count.max() > MAX_OPEN else seg[bad]
            break
        seg, k0, k1, q0, q1 = seg[bad], k0[bad], k1[bad], q0[bad], q1[bad]
        u0, u1 = k0 / _FULL, k1 / _FULL
        km = (k0 + k1) // 2
        um = km / _FULL
        m_tip = tip[seg - 1] + um[:, None] * (tip[seg] - tip[seg - 1])
        m_axis = slerp(axis[seg - 1], axis[seg], um)
        reference = 0.5 * (q0 + q1)
        qm = joints_near(kins, m_tip, m_axis, reference, singular_tilt)
        # keep the joint-space rotary midpoint where its axis is close to the CL axis
        # (smooth rotary motion, e.g. through A = 0) or the piece is pinned; X, Y, Z
        # then put the tip exactly on the CL segment.
        _, ref_axis = kins.forward(reference)
        close = _angle(ref_axis, m_axis) <= 0.5 * angular
        pinned = (u1 - u0) < MIN_PIECE  # split in joint space at a fixed CL pose
        keep = close | pinned
        if keep.any():
            rotary = reference[keep, 3:]
            qm[keep, 3:] = rotary
            qm[keep, :3] = linear_joints(kins, m_tip[keep], rotary)
        seg = np.concatenate([seg, seg])
        k0, k1 = np.concatenate([k0, km]), np.concatenate([km, k1])
        q0, q1 = np.concatenate([q0, qm]), np.concatenate([qm, q1])
    if len(seg):
        first = int(seg.min())
        record = None if records is None else int(records[first])
        place = f"segment to pose {first}" + (f" (record {record})" if record is not None else "")
        place = f"{where}, {place}" if where else place
        turn = np.degrees(joints[first, 3:] - joints[first - 1, 3:])
        raise InputError(
            f"{place}: cannot keep the tool within the chordal/angular tolerance by "
            f"splitting the move (the rotary joints turn by {turn[0]:.3f} and {turn[1]:.3f} "
            "deg in it: a C re-wind or a rotary branch change inside a feed move, or "
            "an axis passing closer to the C axis than the angular tolerance?)",
            field="GOTO",
            value=record,
            accepted="feed moves whose rotary joints stay on one branch and winding",
        )
    all_seg = np.concatenate(done_seg)
    all_key = np.concatenate(done_key)
    order = np.lexsort((all_key, all_seg))
    all_seg, all_key = all_seg[order], all_key[order]
    all_u = all_key / _FULL
    out_tip = tip[all_seg - 1] + all_u[:, None] * (tip[all_seg] - tip[all_seg - 1])
    out_axis = slerp(axis[all_seg - 1], axis[all_seg], all_u)
    return Linearised(
        joints=np.concatenate(done_q)[order],
        tip=out_tip,
        axis=out_axis,
        segment=all_seg,
        inserted=all_key < _FULL,
        tip_length=np.concatenate(done_len)[order],
    )
