"""Shank/holder clearance and undecided contacts by the exact distance kernel.

Two uses of ``body_distance.body_distances`` (GJK of the scene's triangles against
the convex pieces of the posed tool meshes, all postures in one numba call):

* **clearance** of shank+holder: the grid bound first (postures it proves beyond
  the cap keep it), then the bound with the scene's outer grid (postures it proves
  beyond ``cap + BAND`` get ``cap``, the kernel's answer there), then the kernel up
  to ``cap + BAND``. A converged
  interval with ``lower > BAND`` is the distance between the mesh surfaces, fcl's
  value (agreement measured within 1e-12 mm; the kernel's interval is at most
  ``GJK_TOLERANCE`` wide); nothing within ``cap + BAND`` gives the lower bound
  ``cap``. fcl's ``distance`` is called only where the kernel cannot give fcl's
  answer: the solids touch or overlap (``lower <= BAND``: a triangle buried in the
  tool is no surface contact for fcl), the interval did not converge, or the value
  lies within ``BAND`` of one of the caller's ``limits`` (so ``clearance < limit``
  is decided exactly as with fcl's value). Touching solids are first tested with
  ``fcl.collide``: crossing surfaces have fcl distance 0.
* **undecided pairs** (part, role) of the broad phase: a pair whose kernel lower
  bound is above ``BAND`` is clear (the part mesh solid and the role's triangles
  are disjoint, so no surfaces cross: fcl's ``collide`` reports no contact); the
  others stay for ``fcl.collide``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import fcl
import numpy as np
from numpy.typing import NDArray

from cam.collision.body_distance import body_distances
from cam.collision.exact_phase import CLEAR, UNDECIDED
from cam.collision.tool_mesh import PART_NAMES

if TYPE_CHECKING:
    from cam.collision.scene import CollisionScene
    from cam.collision.tool_model import ToolModel

__all__ = ["BAND", "body_clearance", "settle_undecided"]

#: Distances within this of 0 or of a caller's limit are left to fcl, mm.
BAND = 1e-6
#: Widest kernel interval taken as the exact value, mm.
_CONVERGED = 1e-8


def body_clearance(
    scene: CollisionScene,
    model: ToolModel,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    rot: NDArray[np.float64],
    part_hit: NDArray[np.int8],
    cap: float,
    limits: Sequence[float] = (),
) -> tuple[NDArray[np.float64], dict[str, int]]:
    """Shank+holder clearance per posture, mm (0 where they are in contact).

    Parameters
    ----------
    scene : CollisionScene
    model : ToolModel
        With a clearance body (``clear_object`` not None).
    tip, axis : (n, 3) float64
    rot : (n, 3, 3) float64
    part_hit : (n,) int8
        First part in contact per posture (shank 1 or holder 2: clearance 0).
    cap : float
        Exact up to here; above it a lower bound ``>= cap``, mm (may be inf).
    limits : sequence of float
        Values the caller compares the clearance with, mm.

    Returns
    -------
    clearance : (n,) float64
    counts : dict
        ``distance`` (fcl distance calls), ``body_collide`` (fcl collide calls on
        touching solids: a contact means distance 0), ``kernel`` (postures measured by
        the kernel).
    """
    assert model.clear_object is not None and model.clear_spheres is not None
    heights, radii = model.clear_spheres
    body_hit = part_hit >= 1
    if math.isinf(cap):
        clear = np.zeros(len(tip))
        todo = np.flatnonzero(~body_hit)
    else:
        clear = scene.whole.part_bounds(tip, axis, heights, radii, cap)
        clear[body_hit] = 0.0
        todo = np.flatnonzero((clear <= cap) & ~body_hit)
        # with the outer grid too (spheres beyond the scene grid's frame): nothing within
        # cap + BAND, where the kernel would find nothing either and report ``cap``
        far = scene.whole.part_bounds(tip[todo], axis[todo], heights, radii, cap + BAND,
                                      outer=scene.outer)
        clear[todo[far > cap + BAND]] = cap
        todo = todo[far <= cap + BAND]
    roots = np.broadcast_to(scene.arrays.roots, (len(todo), len(scene.arrays.roots)))
    lower, upper = body_distances(scene.arrays.forest, roots, tip[todo], rot[todo],
                                  model.clear_pieces, scene.sections, cap + BAND)
    beyond = np.isinf(upper) & (lower >= cap)
    exact = np.isfinite(upper) & (lower > BAND) & (upper - lower <= _CONVERGED)
    value = np.where(beyond, cap, upper)
    near_limit = np.zeros(len(todo), dtype=bool)
    for limit in limits:
        near_limit |= np.abs(value - limit) <= BAND
    clear[todo] = value
    fallback = todo[~(beyond | exact) | (exact & near_limit)]
    touching = np.zeros(len(tip), dtype=bool)
    touching[todo[lower <= BAND]] = True
    request = fcl.DistanceRequest()
    contact = fcl.CollisionRequest()
    calls = 0
    for i in fallback:
        model.clear_object.setTransform(fcl.Transform(rot[i], tip[i]))
        if touching[i] and fcl.collide(model.clear_object, scene.whole_object, contact,
                                       fcl.CollisionResult()):
            clear[i] = 0.0  # the surfaces cross: fcl's distance is 0
            continue
        calls += 1
        d = fcl.distance(model.clear_object, scene.whole_object, request, fcl.DistanceResult())
        clear[i] = max(float(d), 0.0)
    return clear, {"distance": calls, "body_collide": int(touching[fallback].sum()),
                   "kernel": len(todo)}


def settle_undecided(
    scene: CollisionScene,
    model: ToolModel,
    tip: NDArray[np.float64],
    rot: NDArray[np.float64],
    state: NDArray[np.int8],
) -> int:
    """Mark UNDECIDED pairs CLEAR where the kernel proves the part misses the role.

    Parameters
    ----------
    state : (n, parts, roles) int8
        Broad-phase states, changed in place.

    Returns
    -------
    int
        Pairs measured by the kernel.
    """
    measured = 0
    for code, name in enumerate(PART_NAMES):
        if name not in model.pieces:
            continue
        rows, roles = np.nonzero(state[:, code, :] == UNDECIDED)
        if not rows.size:
            continue
        roots = scene.arrays.roots[roles][:, None]
        lower, _ = body_distances(scene.arrays.forest, roots, tip[rows], rot[rows],
                                  model.pieces[name], scene.sections, 2.0 * BAND)
        clear = lower > BAND
        state[rows[clear], code, roles[clear]] = CLEAR
        measured += int(rows.size)
    return measured
