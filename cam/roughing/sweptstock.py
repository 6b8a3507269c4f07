"""Air in the workpiece frame W: outside the blank, or swept by the tool before.

The stock model the approach moves of both plans share (a 3+2 region's own cuts are
also in its ``stockmap.ZMap``). A cut pose (ball centre ``c``, unit axis ``a``)
leaves the space the tool takes in air: the capsule from ``c`` to ``c + reach a`` of
radius R (ball, flutes and shank up to the holder; like the Z-map's column above the
ball: whether the shank rubs stock left by the layers above is not modelled by
either plan). Cutting runs are sampled every ``step`` mm
along their moves (centre and axis interpolated) and every ``step`` mm up each
sample's axis; the union of balls of radius R about those points lies inside the
swept capsules, and covers every point of them within ``R - shrink`` of their axes
when ``shrink >= R - sqrt(R^2 - step^2 / 2)`` (a point half a step off the samples
both along the move and up the axis), so "within R of a sample" is a conservative
test of "removed", and the tested ball is shrunk by that much (plus 0.01 mm; at
least ``SHRINK``): 0.06 mm for R = 5 and 1 mm steps.

A ball centre ``p`` is **in air** before run ``r`` when every point of the ball
shrunk by ``shrink`` (its centre and ``SPHERE`` points on its surface) is outside
the blank (``Blank.touches`` with radius 0) or within R of a sample of a run before
``r``. ``approach`` finds how far up the axis above a run's start the ball must
come down from to stay in air all the way.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.roughing.stock import Blank

__all__ = ["SweptStock"]

#: The ball tested for air is the tool's ball shrunk by at least this much, mm.
SHRINK = 0.05


def _sphere(n: int = 48) -> NDArray[np.float64]:
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
    """

    def __init__(self, blank: Blank, radius: float, reach: float,
                 runs: list[NDArray[np.float64]], axes: list[NDArray[np.float64]],
                 labels: list[int] | None = None, step: float = 1.0) -> None:
        self.blank = blank
        self.radius = float(radius)
        self.shrink = max(SHRINK, self.radius - math.sqrt(max(
            self.radius ** 2 - step ** 2 / 2.0, 0.0)) + 0.01)
        labels = list(range(len(runs))) if labels is None else list(labels)
        up = np.arange(0.0, max(reach, 0.0) + 1e-9, step)
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
        self.tree = cKDTree(self.points) if len(self.points) else None

    def air(self, centres: NDArray[np.float64], before: int) -> NDArray[np.bool_]:
        """Whether balls at ``centres`` ``(n, 3)`` are in air before run ``before``."""
        c = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        probe = c[:, None] + (self.radius - self.shrink) * np.concatenate(
            [np.zeros((1, 3)), SPHERE])[None]
        flat = probe.reshape(-1, 3)
        ok = ~self.blank.touches(flat, 0.0)
        prefix = int(np.searchsorted(self.labels, before, side="left"))
        if self.tree is not None and prefix > 0 and not ok.all():
            rest = np.flatnonzero(~ok)
            d, idx = self.tree.query(flat[rest], k=8, distance_upper_bound=self.radius)
            within = np.isfinite(d)
            ok[rest] = (within & (idx < prefix)).any(axis=1)
            # all 8 nearest within R but from later runs: look at every sample in reach
            unsure = np.flatnonzero(within.all(axis=1) & ~ok[rest])
            for i in rest[unsure].tolist():
                near = self.tree.query_ball_point(flat[i], self.radius)
                ok[i] = bool(near) and min(near) < prefix
        return np.asarray(ok.reshape(probe.shape[:2]).all(axis=1))

    def approach(self, start: NDArray[np.float64], axis: NDArray[np.float64], top: float,
                 before: int, step: float = 0.5) -> float:
        """Lowest ``t`` in ``[0, top]`` such that the ball stays in air from
        ``start + top axis`` down to ``start + t axis`` (before run ``before``), mm.

        ``top`` itself must be in air (the caller's clear point).
        """
        t = np.arange(top, -1e-9, -step)
        if not len(t):
            return top
        ok = self.air(start[None] + t[:, None] * axis[None], before)
        bad = np.flatnonzero(~ok)
        if not len(bad):
            return 0.0
        return float(t[bad[0] - 1]) if bad[0] > 0 else float(top)


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
