"""Point spacing of a finishing path from a chordal tolerance.

The tool moves on straight lines between consecutive ball centres. On a curve of
radius rho a chord of length c deviates from the arc by the sagitta
``e = rho - sqrt(rho^2 - c^2 / 4)``, so the chord error stays within ``e`` when

    c <= 2 sqrt(e (2 rho - e)).

``chord_spacing`` takes the smallest radius of curvature of a densely sampled path
(Menger curvature of consecutive point triples) and returns the largest spacing
that keeps every chord within the tolerance, capped by the caller's spacing
(``FinishOptions.point_spacing_mm``). The paths are then resampled uniformly in arc
length at that spacing (``paths._resample``): one spacing per path, set by its
most curved stretch, the curvature measured on samples a quarter of the resulting
spacing apart (``refined_spacing``). ``chord_errors`` measures the result (the distance of points
of the curve between two samples from their chord).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["DENSE_SAMPLES", "chord_errors", "chord_spacing", "curvature", "refined_spacing"]

Array = NDArray[np.float64]
#: Samples per point spacing of the dense curve the curvature is measured on.
DENSE_SAMPLES = 4
#: Refinements of the dense sampling (``refined_spacing``).
_REFINEMENTS = 4


def refined_spacing(measure: Callable[[float], float], cap: float) -> float:
    """The spacing ``measure`` allows, measured on samples a quarter of it apart, mm.

    Parameters
    ----------
    measure : callable
        ``measure(step)``: the allowed spacing (at most ``cap``) measured on the
        path sampled ``step`` apart (``chord_spacing`` of the samples), mm.
    cap : float
        Largest spacing, mm.

    Notes
    -----
    The first measurement samples at ``cap / DENSE_SAMPLES``; while the answer is
    below ``DENSE_SAMPLES`` sampling steps the path is sampled again at a quarter
    of it (at most ``_REFINEMENTS`` times), so the curvature is resolved at the
    scale of the chords that are to follow it.
    """
    step = cap / DENSE_SAMPLES
    spacing = measure(step)
    for _ in range(_REFINEMENTS):
        if spacing >= DENSE_SAMPLES * step * (1.0 - 1e-9):
            break
        step = spacing / DENSE_SAMPLES
        spacing = min(spacing, measure(step))
    return spacing


def curvature(points: Array) -> Array:
    """Menger curvature of each triple of consecutive points, 1/mm, ``(n - 2,)``.

    ``4 area / (|a| |b| |c|)`` of the triangle of points ``i, i + 1, i + 2``: the
    inverse radius of the circle through them (0 for collinear points).

    Parameters
    ----------
    points : (n, 3) float64
        Points along a curve, mm (n >= 3; distinct consecutive points).
    """
    a = points[1:-1] - points[:-2]
    b = points[2:] - points[1:-1]
    c = points[2:] - points[:-2]
    twice_area = np.linalg.norm(np.cross(a, b), axis=1)
    lengths = (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
               * np.linalg.norm(c, axis=1))
    return np.asarray(np.where(lengths > 0.0, 2.0 * twice_area / np.where(
        lengths > 0.0, lengths, 1.0), 0.0))


def chord_spacing(dense: Array, tolerance: float, cap: float) -> float:
    """Largest spacing whose chords stay within ``tolerance`` of the curve, mm.

    Parameters
    ----------
    dense : (n, 3) float64
        The curve sampled densely (spacing well below the result), mm.
    tolerance : float
        Largest chord error, mm (> 0).
    cap : float
        Largest spacing returned, mm.

    Returns
    -------
    float
        ``min(cap, 2 sqrt(e (2 rho - e)))`` with rho the smallest radius of
        curvature of ``dense`` (``cap`` for a straight curve or when the
        tolerance exceeds rho).
    """
    if len(dense) < 3:
        return float(cap)
    kappa = float(curvature(dense).max())
    if kappa <= 0.0:
        return float(cap)
    rho = 1.0 / kappa
    if tolerance >= rho:
        return float(cap)
    return float(min(cap, 2.0 * math.sqrt(tolerance * (2.0 * rho - tolerance))))


def chord_errors(points: Array, between: Array) -> Array:
    """Distance of curve points between two samples from their chord, mm.

    Parameters
    ----------
    points : (n, 3) float64
        The path's points.
    between : (n - 1, m, 3) float64
        Points of the true curve between points ``i`` and ``i + 1``.

    Returns
    -------
    (n - 1,) float64
        Per segment the largest distance of its ``between`` points from the
        segment ``points[i] -> points[i + 1]``.
    """
    start, end = points[:-1, None, :], points[1:, None, :]
    edge = end - start
    length2 = np.maximum(np.einsum("ijk,ijk->ij", edge, edge), 1e-300)
    t = np.clip(np.einsum("ijk,ijk->ij", between - start, edge) / length2, 0.0, 1.0)
    foot = start + t[..., None] * edge
    return np.asarray(np.linalg.norm(between - foot, axis=2).max(axis=1))
