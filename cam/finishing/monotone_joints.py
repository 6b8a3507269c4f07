"""A and C without reverse movements on a finishing path (M3 step 2).

``reversal_counts`` counts the reverse movements of every machine axis;
``remove_reversals`` smooths A and C (``reversals.smooth_monotone``) until they are
monotone, keeping the ball centres: the new axes come from the forward kinematics and
the joints from the inverse kinematics, as the post computes them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam.finishing.options import FinishOptions
from cam.finishing.reversals import SmoothingResult, count_reversals, smooth_monotone
from impeller_cam.errors import InputError
from postproc.kinematics import Kinematics

__all__ = ["LINEAR", "ROTARY", "inverse_joints", "remove_reversals", "reversal_counts"]

Array = NDArray[np.float64]
#: Outer rounds (smooth -> inverse kinematics -> count) of the reversal removal.
_OUTER_ROUNDS = 3
ROTARY = ("A", "C")
LINEAR = ("X", "Y", "Z")


def reversal_counts(joints: Array, options: FinishOptions) -> dict[str, int]:
    """Reverse movements per axis of ``(n, 5)`` joints (X Y Z mm, A C rad)."""
    angular = math.radians(options.reversal_deadband_deg)
    out = {name: count_reversals(joints[:, i], options.linear_deadband_mm)
           for i, name in enumerate(LINEAR)}
    out.update({name: count_reversals(joints[:, 3 + i], angular)
                for i, name in enumerate(ROTARY)})
    return out


def _path_parameter(centre: Array) -> Array:
    """Normalised arc length of the ball centres, strictly increasing in [0, 1]."""
    step = np.linalg.norm(np.diff(centre, axis=0), axis=1)
    step = np.maximum(step, 1e-9 * max(float(step.max()), 1.0))
    arc = np.concatenate([[0.0], np.cumsum(step)])
    return np.asarray(arc / arc[-1])


def inverse_joints(kins: Kinematics, tip: Array, axis: Array, name: str) -> Array:
    """Joints ``(n, 5)`` of the postures; ``InputError`` naming the path when the
    machine cannot reach one."""
    try:
        return kins.inverse(tip, axis)
    except InputError as error:
        raise InputError(f"path {name}: {error}", field="machine",
                         accepted="a machine whose axes reach every finishing posture") \
            from error


def remove_reversals(centre: Array, axis: Array, joints: Array, kins: Kinematics,
                     radius: float, options: FinishOptions, name: str = "path"
                     ) -> tuple[Array, Array, dict[str, SmoothingResult]]:
    """Smooth A and C until monotone; new axes from the forward kinematics.

    The ball centres are kept: the tips are ``centre - R axis`` for the new axes.

    Returns
    -------
    axis : (n, 3) float64
    joints : (n, 5) float64
        Joints of the new postures (inverse kinematics, as the post will compute them).
    smoothing : dict
        ``{"A": SmoothingResult, "C": SmoothingResult}`` of the last round that changed
        the axis (``method == "none"`` when nothing was needed).
    """
    t = _path_parameter(centre)
    deadband = math.radians(options.reversal_deadband_deg)
    done = {k: SmoothingResult(joints[:, 3 + i].copy(), 0, [], "none")
            for i, k in enumerate(ROTARY)}
    for _ in range(_OUTER_ROUNDS):
        counts = [count_reversals(joints[:, 3 + i], deadband) for i in range(2)]
        if not any(counts):
            break
        smoothed = joints.copy()
        for i, key in enumerate(ROTARY):
            if counts[i]:
                result = smooth_monotone(
                    t, joints[:, 3 + i], basis_functions=options.basis_functions,
                    min_shift=math.radians(options.phi_l_deg), deadband=deadband,
                    max_rounds=options.max_smoothing_iterations,
                    scope=options.smoothing_scope)
                smoothed[:, 3 + i] = result.values
                done[key] = result
        _, axis = kins.forward(smoothed)
        joints = inverse_joints(kins, centre - radius * axis, axis, name)
    return axis, joints, done
