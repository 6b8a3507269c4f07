"""Narrow phase: the first contact of each posture from the classified pairs, with fcl.

``state[i, part, role]`` holds ``CLEAR``, ``UNDECIDED`` or ``HIT`` for every
posture, tool part (cutter, shank, holder) and scene role. The answer of a
posture is the first pair, in part-major order, that touches: a posture whose
first non-clear pair is a definite hit is answered without fcl (vectorised);
the others call ``fcl.collide`` on their undecided pairs in order until a
contact (a definite hit met on the way is a contact).
"""

from __future__ import annotations

from collections.abc import Sequence

import fcl
import numpy as np
from numpy.typing import NDArray

from cam.collision.exact_phase import CLEAR, HIT, UNDECIDED


def first_contacts(
    part_objects: Sequence[fcl.CollisionObject | None],
    role_objects: Sequence[fcl.CollisionObject],
    tip: NDArray[np.float64],
    rot: NDArray[np.float64],
    state: NDArray[np.int8],
) -> tuple[NDArray[np.bool_], NDArray[np.int8], NDArray[np.int64], dict[str, int]]:
    """First contact per posture.

    Parameters
    ----------
    part_objects : sequence of fcl.CollisionObject or None
        The tool parts in part order (None: the tool has no such part; its pairs
        must be CLEAR).
    role_objects : sequence of fcl.CollisionObject
        The scene meshes in role order.
    tip : (n, 3) float64
        Tool tips, mm.
    rot : (n, 3, 3) float64
        Tool-frame rotations.
    state : (n, parts, roles) int8

    Returns
    -------
    collides : (n,) bool
    part : (n,) int8
        Part index of the first contact, -1 for none.
    role : (n,) int64
        Role index of the first contact, -1 for none.
    counts : dict
        ``collide`` (fcl calls), ``definite_hits``, ``narrow_postures``.
    """
    n = len(tip)
    roles = state.shape[2]
    collides = np.zeros(n, dtype=bool)
    part_hit = np.full(n, -1, dtype=np.int8)
    role_hit = np.full(n, -1, dtype=np.int64)
    flat = state.reshape(n, state.shape[1] * roles)  # n may be 0
    first = np.argmax(flat != CLEAR, axis=1)
    first_state = flat[np.arange(n), first]
    decided = first_state == HIT
    collides[decided] = True
    part_hit[decided] = first[decided] // roles
    role_hit[decided] = first[decided] % roles
    definite = int(decided.sum())
    calls = 0
    request = fcl.CollisionRequest()
    pending = np.flatnonzero(first_state == UNDECIDED)
    # the non-clear pairs of the pending postures, posture-major then part-major order
    rows, codes, role_ids = np.nonzero(state[pending] != CLEAR)
    kinds = state[pending[rows], codes, role_ids]
    done = -1
    placed = (-1, -1)
    for row, code, role, kind in zip(
        rows.tolist(), codes.tolist(), role_ids.tolist(), kinds.tolist(), strict=True
    ):
        if row == done:
            continue  # this posture's first contact is known
        i = int(pending[row])
        if kind == UNDECIDED:
            obj = part_objects[code]
            assert obj is not None
            if placed != (row, code):
                obj.setTransform(fcl.Transform(rot[i], tip[i]))
                placed = (row, code)
            calls += 1
            if not fcl.collide(obj, role_objects[role], request, fcl.CollisionResult()):
                continue
        else:
            definite += 1
        collides[i], part_hit[i], role_hit[i] = True, code, role
        done = row
    counts = {"collide": calls, "definite_hits": definite, "narrow_postures": len(pending)}
    return collides, part_hit, role_hit, counts
