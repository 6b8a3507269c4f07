"""Stock short of the design: where the initial stock cuts into the part.

Before the first block, the surface of the stock (its dexel ends,
``Stock.surface_samples``) is measured against the design (those above the design's
highest point at their radius or beyond its largest radius, ``below_design_top``,
are outside it without a distance query). A sample no block has
touched (move id < 0) lying deeper inside the design than the gouge tolerance means
the stock does not contain the part: no program can put that material back. Such
samples are grouped into places (samples in touching cubes of ``CLUSTER`` mm) and
each place is one ``stock_short`` event: its deepest sample, the depth, the number
of samples and the size of the place.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from cam.verify.events import Event

__all__ = ["BAND", "CLUSTER", "below_design_top", "short_places", "stock_short_events"]

#: Edge of the cubes in which short samples are grouped into places, mm (samples in
#: cubes sharing a face, an edge or a corner form one place).
CLUSTER = 1.0
#: Width of the bands of radius of ``below_design_top``, mm.
BAND = 0.5


def below_design_top(points: NDArray[np.float64], triangles: NDArray[np.float64],
                     band: float = BAND) -> NDArray[np.bool_]:
    """Whether each point may lie inside the design: not above its highest point at
    the point's radius (per band of radius, conservatively) nor beyond its largest
    radius.

    A stock's top surface and outer diameter, most of a turned blank's samples, are
    answered here without a distance query.

    Parameters
    ----------
    points : (n, 3) float64
        mm.
    triangles : (t, 3, 3) float64
        The design's triangles, mm.

    Returns
    -------
    (n,) bool
        False only where the point is certainly outside the design.
    """
    radius = np.hypot(triangles[..., 0], triangles[..., 1])
    edge = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    # r is convex along a triangle: its largest value is at a corner, its smallest at
    # most one edge length below the corners'
    lo = np.maximum(radius.min(axis=1) - edge, 0.0)
    hi = radius.max(axis=1)
    top = triangles[..., 2].max(axis=1)
    bands = int(np.ceil(hi.max() / band)) + 1
    first, last = (lo / band).astype(np.int64), (hi / band).astype(np.int64)
    z_top = np.full(bands, -np.inf)
    for k in range(int((last - first).max()) + 1):
        reach = first + k <= last
        np.maximum.at(z_top, (first + k)[reach], top[reach])
    r = np.hypot(points[:, 0], points[:, 1])
    index = (r / band).astype(np.int64)
    inside = index < bands
    out = np.zeros(len(points), dtype=bool)
    out[inside] = points[inside, 2] <= z_top[index[inside]]
    return out


def short_places(points: NDArray[np.float64], cluster: float = CLUSTER
                 ) -> NDArray[np.int64]:
    """Place index of each point: connected groups of occupied cubes of ``cluster`` mm.

    Parameters
    ----------
    points : (n, 3) float64
        mm.

    Returns
    -------
    (n,) int64
        0 .. places - 1.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if not len(points):
        return np.zeros(0, dtype=np.int64)
    cells = np.floor(points / cluster).astype(np.int64)
    unique, of_point = np.unique(cells, axis=0, return_inverse=True)
    pairs = cKDTree(unique.astype(np.float64)).query_pairs(r=1.75, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(unique), len(unique)))
    _, label = connected_components(graph, directed=False)
    return np.asarray(label[np.asarray(of_point).reshape(-1)], dtype=np.int64)


def stock_short_events(points: NDArray[np.float64], signed: NDArray[np.float64],
                       moves: NDArray[np.integer], tolerance: float, program: str
                       ) -> list[Event]:
    """``stock_short`` events of a stock's surface samples, deepest place first.

    Parameters
    ----------
    points : (n, 3) float64
        Stock surface samples, mm.
    signed : (n,) float64
        Their signed distance from the design, mm (negative inside).
    moves : (n,) int
        Move id of the block that last cut each sample (< 0: never cut).
    tolerance : float
        Depth inside the design below which a sample is not short, mm (the gouge
        tolerance: the design mesh's tessellation error).
    program : str
        Program the events are listed under (the first one run on the stock).
    """
    short = np.flatnonzero((np.asarray(moves) < 0) & (signed < -tolerance))
    if not len(short):
        return []
    place = short_places(points[short])
    events = []
    for k in range(int(place.max()) + 1):
        members = short[place == k]
        deepest = members[int(np.argmin(signed[members]))]
        depth = float(-signed[deepest])
        size = float(np.linalg.norm(np.ptp(points[members], axis=0)))
        x, y, z = (float(v) for v in points[deepest])
        events.append(Event(
            "stock_short", 0, program, (x, y, z), depth,
            f"the stock lies {depth:.3f} mm inside the design here ({len(members)} "
            f"surface samples over {size:.1f} mm): it does not contain the part",
            {"samples": len(members), "extent_mm": size},
        ))
    return sorted(events, key=lambda e: -e.amount)
