"""Air in the workpiece frame W: outside the blank, or swept by the tool before.

The stock model the approach moves of both plans share (a 3+2 region's own cuts are
also in its ``stockmap.ZMap``). A cut pose (ball centre ``c``, unit axis ``a``)
leaves the space the tool takes in air: the capsule from ``c`` to ``c + reach a`` of
radius R (ball, flutes and shank up to the holder; like the Z-map's column above the
ball: air if the shank met no stock there, which ``shank.ShankGuard`` ensures for
the 3+2 plan). Cutting runs are sampled every ``step`` mm along their moves (centre
and axis interpolated) and every ``step`` mm up each sample's axis; every sample lies
on a capsule's axis, so a point within R of a sample is removed (the union of those
balls lies inside the swept capsules).

A ball centre ``p`` is **in air** before run ``r`` when the ball of radius
``R + clearance`` about it holds no stock. Tested: its centre and the ``SPHERE``
points on its surface (``rho = R + clearance``), each with a margin
``m = rho * SPHERE_COVER`` (every point of the sphere lies within ``m`` of a tested
point): a tested point counts as air when it is at least ``m`` outside the blank
(``Blank.touches`` with radius ``m``) or within ``R - m`` of a sample of a run
before ``r`` (so the whole ``m``-ball about it is removed). Then no point of the
sphere is stock; stock inside it would have to be an island cut loose from the rest,
which sweeps of the tool from outside do not leave. A ball centred on the axis of a
cut pose, within ``reach`` above it, is in air too (inside the capsule that pose's
tool took: a rapid up the axis out of the cut, which touches the walls it has just
cut and so has no clearance to keep). (The tested ball used to be the
tool's ball shrunk by the sampling error, tested at 48 surface points without a
margin: the stock could reach 0.1 mm plus a 0.2 mm cap between the points into the
tool; the verification found such rapids on the small fixture, 0.03 mm into
stock.)

``approach`` finds how far up the axis above a run's start the ball must come down
from to stay in air all the way, testing every ``step`` mm (default 0.25): every pose
of the descent is within ``step / 2`` of a tested one, so the tool's ball keeps
``clearance - step / 2`` (``RAPID_CLEARANCE`` 0.25 mm: 0.125 mm) from the stock.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from cam.roughing.stock import Blank

__all__ = ["APPROACH_STEP", "KEPT_CLEARANCE", "RAPID_CLEARANCE", "SweptStock"]

#: The ball tested for air is the tool's ball grown by this much, mm.
RAPID_CLEARANCE = 0.25
#: Spacing of the descent poses ``approach`` tests, mm.
APPROACH_STEP = 0.25
#: What ``approach`` guarantees between its tested poses (``RAPID_CLEARANCE - step /
#: 2``), mm; the rapid check (``cam.roughing.aircheck``) verifies this clearance.
KEPT_CLEARANCE = RAPID_CLEARANCE - 0.5 * APPROACH_STEP
#: A ball centre this close to a cut pose's axis is on it, mm.
ON_AXIS = 1e-6
#: Points of the unit sphere tested (``SPHERE``).
SPHERE_POINTS = 1000
#: Covering radius of ``SPHERE`` on the unit sphere: every unit vector lies within
#: this (chord) distance of a ``SPHERE`` point (0.0836 measured on 2e5 random unit
#: vectors, rounded up; tests/cam/test_roughing_formulas.py checks it).
SPHERE_COVER = 0.09


def _sphere(n: int = SPHERE_POINTS) -> NDArray[np.float64]:
    """``n`` unit vectors spread over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


SPHERE = _sphere()


class SweptStock:
    """What a list of cutting runs has removed from the blank (see module docstring).

    Parameters
    ----------
    blank : Blank
    radius : float
        Ball radius R, mm.
    reach : float
        Length of the tool's cylinder above the ball centre (stick-out - R), mm.
    runs, axes : list of (k, 3) float64
        Ball centres and unit axes of the cutting runs in program order (W).
    labels : sequence of int, optional
        Order label of each run (default 0, 1, ...): ``before=r`` counts the runs
        labelled below ``r``.
    step : float
        Sample spacing along the moves and up the axes, mm.
    clearance : float
        The ball tested for air is R + ``clearance``, mm.
    """

    def __init__(self, blank: Blank, radius: float, reach: float,
                 runs: list[NDArray[np.float64]], axes: list[NDArray[np.float64]],
                 labels: list[int] | None = None, step: float = 1.0,
                 clearance: float = RAPID_CLEARANCE) -> None:
        self.blank = blank
        self.radius = float(radius)
        self.clearance = float(clearance)
        self.probe_radius = self.radius + self.clearance
        self.margin = self.probe_radius * SPHERE_COVER
        self.reach = max(float(reach), 0.0)
        labels = list(range(len(runs))) if labels is None else list(labels)
        up = np.arange(0.0, self.reach + 1e-9, step)
        pts: list[NDArray[np.float64]] = []
        lab: list[NDArray[np.int64]] = []
        for run, ax, label in zip(runs, axes, labels, strict=True):
            c, a = _along(run, ax, step)
            s = (c[:, None] + up[None, :, None] * a[:, None]).reshape(-1, 3)
            pts.append(s)
            lab.append(np.full(len(s), label, np.int64))
        self.points = np.concatenate(pts) if pts else np.zeros((0, 3))
        self.labels = np.concatenate(lab) if lab else np.zeros(0, np.int64)
        order = np.argsort(self.labels, kind="stable")  # labels ascending: "before" is a prefix
        self.points, self.labels = self.points[order], self.labels[order]
        self._grid = _LabelGrid(self.points, self.labels, 0.5 * self.radius)
        # the poses themselves (ball centre, axis, label): a ball on a pose's axis
        poses = [(np.asarray(r, np.float64), np.asarray(a, np.float64), label)
                 for r, a, label in zip(runs, axes, labels, strict=True) if len(r)]
        self.poses = np.concatenate([r for r, _, _ in poses]) if poses else np.zeros((0, 3))
        self.pose_axes = np.concatenate([a for _, a, _ in poses]) if poses else np.zeros((0, 3))
        self.pose_labels = (np.concatenate([np.full(len(r), label, np.int64)
                                            for r, _, label in poses])
                            if poses else np.zeros(0, np.int64))

    def air(self, centres: NDArray[np.float64], before: int) -> NDArray[np.bool_]:
        """Whether balls of radius R + clearance at ``centres`` ``(n, 3)`` hold no stock
        before run ``before`` (module docstring)."""
        c = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        # a centre farther than R + clearance + m from the blank: every tested point
        # of its ball is at least m outside it
        inside = ~self.blank.touches(c, self.probe_radius + self.margin + 1e-9)
        near = np.flatnonzero(~inside)
        if len(near):
            probe = c[near, None] + self.probe_radius * np.concatenate(
                [np.zeros((1, 3)), SPHERE])[None]
            flat = probe.reshape(-1, 3)
            ok = ~self.blank.touches(flat, self.margin)
            rest = np.flatnonzero(~ok)
            ok[rest] = self._removed(flat[rest], before, self.radius - self.margin)
            inside[near] = ok.reshape(probe.shape[:2]).all(axis=1)
        for i in np.flatnonzero(~inside).tolist():
            inside[i] = self._on_a_column(c[i], before)
        return np.asarray(inside)

    def stock(self, points: NDArray[np.float64], before: int) -> NDArray[np.bool_]:
        """Whether points ``(n, 3)`` are stock before run ``before``: inside the blank
        and not within R of a sample of an earlier run (conservative: a point in the
        swept volume's skin between the sampled balls counts as stock)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = self.blank.touches(p, 0.0)
        inside = np.flatnonzero(out)
        out[inside] = ~self._removed(p[inside], before, self.radius)
        return np.asarray(out)

    def _removed(self, points: NDArray[np.float64], before: int, within: float
                 ) -> NDArray[np.bool_]:
        """Whether points ``(n, 3)`` lie within ``within`` of a sample of a run
        labelled below ``before`` (so inside what that run swept)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        if within <= 0.0 or not len(p) or not len(self.points):
            return np.zeros(len(p), dtype=bool)
        return self._grid.any_before(p, before, within)

    def _on_a_column(self, centre: NDArray[np.float64], before: int) -> bool:
        """The ball at ``centre`` lies on the axis of a cut pose of a run before
        ``before``, within ``reach`` above it: inside the capsule that pose's tool
        took (a rapid up the axis out of the cut, in contact with the walls it has
        just cut, zero clearance)."""
        earlier = self.pose_labels < before
        if not earlier.any():
            return False
        rel = centre[None] - self.poses[earlier]
        along = np.einsum("ij,ij->i", rel, self.pose_axes[earlier])
        off = np.linalg.norm(rel - along[:, None] * self.pose_axes[earlier], axis=1)
        return bool(np.any((off <= ON_AXIS) & (along >= -ON_AXIS)
                           & (along <= self.reach + ON_AXIS)))

    def approach(self, start: NDArray[np.float64], axis: NDArray[np.float64], top: float,
                 before: int, step: float = APPROACH_STEP, chunk: int = 32) -> float:
        """Lowest ``t`` in ``[0, top]`` such that the ball stays in air from
        ``start + top axis`` down to ``start + t axis`` (before run ``before``), mm.

        Tested every ``step`` mm from ``top`` down (``chunk`` poses at a time, until
        the first one not in air). ``top`` itself must be in air (the caller's clear
        point); when it is not, ``top`` is returned.
        """
        t = np.arange(top, -1e-9, -step)
        if not len(t):
            return top
        for lo in range(0, len(t), chunk):
            part = t[lo:lo + chunk]
            ok = self.air(start[None] + part[:, None] * axis[None], before)
            bad = np.flatnonzero(~ok)
            if len(bad):
                first = lo + int(bad[0])
                return float(t[first - 1]) if first > 0 else float(top)
        return 0.0


    def rise(self, start: NDArray[np.float64], axis: NDArray[np.float64], bottom: float,
             limit: float, before: int, step: float = APPROACH_STEP) -> float:
        """Lowest ``t`` in ``[bottom, limit]`` (every ``step`` mm up) at which the ball
        at ``start + t axis`` is in air before run ``before``; ``limit`` if none."""
        t = np.arange(bottom, limit, step)
        for lo in range(0, len(t), 32):
            part = t[lo:lo + 32]
            ok = np.flatnonzero(self.air(start[None] + part[:, None] * axis[None], before))
            if len(ok):
                return float(part[ok[0]])
        return float(limit)


class _LabelGrid:
    """Labelled points in a uniform grid of cubes, each cube's points in label order:
    whether a point lies within ``r`` of a point labelled below ``before`` looks at
    the cubes around it and, in each, only at its points labelled below ``before``
    (``_any_before``).

    Parameters
    ----------
    points : (n, 3) float64
    labels : (n,) int64
    cell : float
        Edge of the cubes, mm (grown where the grid would exceed ``MAX_CELLS``).
    """

    #: Cubes of the grid at most (its memory: 8 bytes per cube).
    MAX_CELLS = 4_000_000

    def __init__(self, points: NDArray[np.float64], labels: NDArray[np.int64],
                 cell: float) -> None:
        lo = points.min(axis=0) if len(points) else np.zeros(3)
        hi = points.max(axis=0) if len(points) else np.zeros(3)
        span = hi - lo
        cell = max(float(cell), 1e-3, float(np.prod(span + 1e-9) / self.MAX_CELLS) ** (1 / 3))
        dims = np.floor(span / cell).astype(np.int64) + 1
        while int(np.prod(dims)) > self.MAX_CELLS:
            cell *= 1.25
            dims = np.floor(span / cell).astype(np.int64) + 1
        key = _cell_keys(np.ascontiguousarray(points), lo, cell, dims)
        order = np.lexsort((labels, key))  # by cube, then by label
        self.origin, self.cell, self.dims = lo, cell, dims
        self.points = np.ascontiguousarray(points[order])
        self.labels = np.ascontiguousarray(labels[order])
        counts = np.bincount(key, minlength=int(np.prod(dims)))
        self.start = np.concatenate([[0], np.cumsum(counts)])  # cube k: start[k]:start[k+1]

    def any_before(self, points: NDArray[np.float64], before: int, within: float
                   ) -> NDArray[np.bool_]:
        """Whether each of ``points`` ``(m, 3)`` lies closer than ``within`` (mm) to a
        point labelled below ``before``."""
        reach = int(math.ceil(within / self.cell))
        return np.asarray(_any_before(points, self.points, self.labels, self.start,
                                      self.origin, self.cell, self.dims, int(before),
                                      float(within), reach))


@njit(cache=True, nogil=True)
def _cell_keys(points: NDArray[np.float64], origin: NDArray[np.float64], cell: float,
               dims: NDArray[np.int64]) -> NDArray[np.int64]:
    """Flat index of each point's cube (points inside the grid's box)."""
    out = np.empty(points.shape[0], dtype=np.int64)
    for i in range(points.shape[0]):
        cx = min(max(int(math.floor((points[i, 0] - origin[0]) / cell)), 0), dims[0] - 1)
        cy = min(max(int(math.floor((points[i, 1] - origin[1]) / cell)), 0), dims[1] - 1)
        cz = min(max(int(math.floor((points[i, 2] - origin[2]) / cell)), 0), dims[2] - 1)
        out[i] = (cx * dims[1] + cy) * dims[2] + cz
    return out


@njit(cache=True, nogil=True)
def _gap(p: float, low: float, cell: float) -> float:
    """Distance along one axis from ``p`` to the interval ``[low, low + cell]``, less
    1e-9 mm (a point's cube is found by rounding)."""
    return max(low - p - 1e-9, 0.0, p - low - cell - 1e-9)


@njit(cache=True, nogil=True)
def _any_before(points: NDArray[np.float64], grid_points: NDArray[np.float64],
                labels: NDArray[np.int64], start: NDArray[np.int64],
                origin: NDArray[np.float64], cell: float, dims: NDArray[np.int64],
                before: int, within: float, reach: int) -> NDArray[np.bool_]:
    """``_LabelGrid.any_before``: the cubes within ``reach`` cubes of each point's,
    each read in label order up to the first label at or above ``before``."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    w2 = within * within
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        cx = int(math.floor((px - origin[0]) / cell))
        cy = int(math.floor((py - origin[1]) / cell))
        cz = int(math.floor((pz - origin[2]) / cell))
        found = False
        for x in range(max(cx - reach, 0), min(cx + reach, dims[0] - 1) + 1):
            gx = _gap(px, origin[0] + x * cell, cell)
            for y in range(max(cy - reach, 0), min(cy + reach, dims[1] - 1) + 1):
                gy = _gap(py, origin[1] + y * cell, cell)
                for z in range(max(cz - reach, 0), min(cz + reach, dims[2] - 1) + 1):
                    gz = _gap(pz, origin[2] + z * cell, cell)
                    if gx * gx + gy * gy + gz * gz >= w2:
                        continue  # the whole cube lies too far
                    key = (x * dims[1] + y) * dims[2] + z
                    for j in range(start[key], start[key + 1]):
                        if labels[j] >= before:
                            break
                        dx = grid_points[j, 0] - px
                        dy = grid_points[j, 1] - py
                        dz = grid_points[j, 2] - pz
                        if dx * dx + dy * dy + dz * dz < w2:
                            found = True
                            break
                    if found:
                        break
                if found:
                    break
            if found:
                break
        out[i] = found
    return out


def _along(run: NDArray[np.float64], axes: NDArray[np.float64], step: float
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Centres and unit axes every ``step`` mm along a run's moves (its poses too)."""
    if len(run) < 2:
        return run, axes
    a, b = run[:-1], run[1:]
    n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(np.int64), 1)
    owner = np.repeat(np.arange(len(n)), n)
    first = np.repeat(np.cumsum(n) - n, n)
    t = ((np.arange(len(owner)) - first + 1) / n[owner])[:, None]
    c = a[owner] + t * (b - a)[owner]
    ax = axes[:-1][owner] + t * (axes[1:] - axes[:-1])[owner]
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    return np.concatenate([run[:1], c]), np.concatenate([axes[:1], ax])
