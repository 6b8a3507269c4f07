"""Closed blade sections -> mean line and thickness: split at the edges, pair the sides.

A section is a closed loop of points around the blade at one span. The loop is cut
at the leading and trailing edges into two sides that are paired point for point:
among every split whose two sides have the same number of points (an edge is either
one loop point, the apex of a rounded edge, or one loop segment, the face of a cut
edge), the one with the smallest sum of squared gaps between paired points is
taken -- for a thin blade, points facing each other across the blade are the
closest. The end nearer the inlet along the hub contour is the leading edge.

Pair ``k`` gives a mean-line point (the midpoint) and a thickness (the gap). At a
rounded edge the pairs of the cap are dropped: the mean line starts at the first
pair whose midpoint is at least as far from the apex as its half gap (to within
``CAP_SLACK``), the cap's centre for a circular cap. A cut edge keeps its end pair
(the face's two corners).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from geometry.mesh_query import polyline_projection

__all__ = ["CAP_SLACK", "SectionSplit", "split_section"]

Array = NDArray[np.float64]
#: A pair ends a rounded cap while |midpoint - apex| <= (1 + CAP_SLACK) * half gap.
CAP_SLACK = 0.2


class SectionSplit:
    """A section cut into paired sides.

    Attributes
    ----------
    mean : (n, 3) float64
        Mean-line points (cartesian mm), leading to trailing edge, caps dropped.
    thickness : (n,) float64
        Gap between the paired points, mm.
    fraction : (n,) float64
        Normalised cumulative chord length of ``mean``.
    leading_point, trailing_point : bool
        Whether each edge is a single loop point (an apex) or a segment (a face).
    """

    def __init__(self, mean: Array, thickness: Array, leading_point: bool,
                 trailing_point: bool) -> None:
        self.mean = mean
        self.thickness = thickness
        steps = np.linalg.norm(np.diff(mean, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(steps)])
        self.fraction = s / s[-1] if s[-1] > 0 else s
        self.leading_point = leading_point
        self.trailing_point = trailing_point


def _candidates(n: int) -> list[tuple[NDArray[np.int64], NDArray[np.int64], bool, bool]]:
    """Index arrays (A, B) of every equal-count split of an n-point loop, with end kinds."""
    out = []
    starts = np.arange(n)[:, None]
    if n % 2 == 0:
        k = n // 2 + 1                        # apex to apex
        steps = np.arange(k)[None, :]
        out.append(((starts + steps) % n, (starts - steps) % n, True, True))
        k = n // 2                            # face to face
        out.append(((starts + steps[:, :k]) % n, (starts - 1 - steps[:, :k]) % n, False, False))
    else:
        k = (n + 1) // 2                      # apex to face
        steps = np.arange(k)[None, :]
        out.append(((starts + steps) % n, (starts - steps) % n, True, False))
    return out  # type: ignore[return-value]


def _pairs(loop: Array) -> tuple[Array, Array, bool, bool]:
    """Best split of ``loop`` (n, 3): the two sides (k, 3) each, and the end kinds."""
    best: tuple[float, Array, Array, bool, bool] | None = None
    for a, b, first_point, last_point in _candidates(len(loop)):
        gaps = np.sum((loop[a] - loop[b]) ** 2, axis=(1, 2))
        i = int(np.argmin(gaps))
        if best is None or gaps[i] < best[0]:
            best = (float(gaps[i]), loop[a[i]], loop[b[i]], first_point, last_point)
    assert best is not None
    return best[1], best[2], best[3], best[4]


def _cap_end(mid: Array, half: Array) -> int:
    """Index of the first pair past a rounded cap starting at pair 0."""
    apex = mid[0]
    far = np.linalg.norm(mid - apex, axis=1) > (1.0 + CAP_SLACK) * half
    far[0] = False
    beyond = int(np.argmax(far)) if np.any(far) else len(mid)
    return max(beyond - 1, 0)


def split_section(loop: Array, hub_polyline: Array, leading_edge: str,
                  trailing_edge: str) -> SectionSplit:
    """Mean line and thickness of one closed section.

    Parameters
    ----------
    loop : (n, 3) float64
        Section points in loop order, cartesian mm, the closing point not repeated.
    hub_polyline : (k, 2) float64
        Hub contour ``z, r`` oriented inlet to outlet (decides which end leads).
    leading_edge, trailing_edge : str
        ``"round"`` (a cap to drop) or ``"cut"``.

    Returns
    -------
    SectionSplit
    """
    side_a, side_b, first_point, last_point = _pairs(loop)
    ends = np.array([[side_a[0, 2], np.hypot(*side_a[0, :2])],
                     [side_a[-1, 2], np.hypot(*side_a[-1, :2])]])
    position, _, _ = polyline_projection(ends, hub_polyline)
    if position[1] < position[0]:
        side_a, side_b = side_a[::-1], side_b[::-1]
        first_point, last_point = last_point, first_point
    mid = 0.5 * (side_a + side_b)
    half = 0.5 * np.linalg.norm(side_a - side_b, axis=1)
    start, stop = 0, len(mid) - 1
    if leading_edge == "round":
        start = _cap_end(mid, half)
    if trailing_edge == "round":
        stop = len(mid) - 1 - _cap_end(mid[::-1], half[::-1])
    return SectionSplit(mid[start:stop + 1], 2.0 * half[start:stop + 1], first_point,
                        last_point)
