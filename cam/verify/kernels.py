"""Numba kernels of the tri-dexel engine: swept-primitive intervals and dexel subtraction.

``swept_interval`` is the general, exact ray interval of a swept primitive and the
accuracy reference of the closed forms in ``cam.verify.interval``; ``sweep_moves`` is
the straightforward per-primitive sweep (every ray of the bounding box, the general
interval on each), kept as the reference the fast engine ``cam.verify.sweep`` is
tested against (tests/cam/test_verify_engine.py).

A dexel grid ``k`` holds rays parallel to world axis ``k`` through the centres of a
square grid of pitch ``h`` over the other two axes (``i = (k+1) % 3``,
``j = (k+2) % 3``). Each ray holds sorted, disjoint material intervals in a shared
pool: ray ``r`` owns ``pool[start[r] : start[r] + cap[r]]`` and uses the first
``count[r]``. Each interval end remembers the index of the move that made it
(``-1``: the initial stock), which is how a gouge is tied to its NC line.

Swept primitive on a ray (exact, closed form)
---------------------------------------------
A convex primitive ``K`` (``cam.verify.toolshape``: quadric ``Q <= 0`` inside a slab
``zlo <= z <= zhi`` of the tool frame) swept along a straight move ``tip0 + s d``,
``0 <= s <= 1``, with a fixed axis ``a``. A ray point ``o + t e_k`` is in the sweep
iff some ``s`` in ``[0, 1]`` has ``o + t e_k - tip0 - s d`` in ``K``. In the plane
``(t, s)`` this set is the plane section of ``K`` (a conic region) cut by the lines
``s = 0``, ``s = 1``, ``z = zlo``, ``z = zhi``: convex, so its projection on ``t`` is
one interval. The extremes of ``t`` over a convex region bounded by a conic arc and
straight lines lie at (1) corners of two lines, (2) crossings of a line with the
conic, or (3) points of the conic where ``dQ/ds = 0`` (tangent parallel to ``s``).
All three are roots of at most quadratic equations; the kernel evaluates them and
keeps the feasible ones. No sampling: the interval is exact up to round-off.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_EPS_LIN = 1e-9  # mm: slack on the linear constraints of a candidate point
_EPS_Q = 1e-7  # mm^2: slack on Q <= 0 for corner candidates
_REL_Q = 1e-9  # relative slack on Q = 0 for a root of a line and the conic
_TINY = 1e-14
#: Pieces shorter than this (mm) left by a subtraction are dropped.
MIN_PIECE = 1e-6


@njit(cache=True)
def _q(t, s, qa, qb, qc, qd, qe, qf):  # type: ignore[no-untyped-def]
    return qa * t * t + 2.0 * qb * t * s + qc * s * s + 2.0 * qd * t + 2.0 * qe * s + qf


@njit(cache=True)
def _feasible(t, s, zw, zu, zd, zlo, zhi):  # type: ignore[no-untyped-def]
    if s < -_EPS_LIN or s > 1.0 + _EPS_LIN:
        return False
    z = zw + zu * t - zd * s
    return z >= zlo - _EPS_LIN and z <= zhi + _EPS_LIN


@njit(cache=True)
def _line_roots(ct, cs, c0, qa, qb, qc, qd, qe, qf):  # type: ignore[no-untyped-def]
    """Points of ``ct t + cs s + c0 = 0`` on ``Q = 0``: ``(count, t1, s1, t2, s2)``.

    The line is walked with a unit direction, so the quadratic's coefficients keep
    the scale of ``Q`` itself; a short move makes ``ct``, ``cs`` tiny (the tangency
    line ``dQ/ds = 0``), and an unnormalised direction used to turn a genuine quadratic
    into a "linear" one whose root was not on the conic at all.
    """
    nrm = math.sqrt(ct * ct + cs * cs)
    if nrm < _TINY:
        return 0, 0.0, 0.0, 0.0, 0.0
    ct /= nrm
    cs /= nrm
    c0 /= nrm
    p0t = -c0 * ct
    p0s = -c0 * cs
    qt = -cs
    qs = ct
    a2 = qa * qt * qt + 2.0 * qb * qt * qs + qc * qs * qs
    a1 = 2.0 * (qa * p0t * qt + qb * (p0t * qs + p0s * qt) + qc * p0s * qs + qd * qt + qe * qs)
    a0 = _q(p0t, p0s, qa, qb, qc, qd, qe, qf)
    if a2 == 0.0:
        if a1 == 0.0:
            return 0, 0.0, 0.0, 0.0, 0.0
        lam = -a0 / a1
        return 1, p0t + lam * qt, p0s + lam * qs, 0.0, 0.0
    disc = a1 * a1 - 4.0 * a2 * a0
    if disc < 0.0:
        if disc > -1e-10 * (a1 * a1 + abs(4.0 * a2 * a0)):
            disc = 0.0
        else:
            return 0, 0.0, 0.0, 0.0, 0.0
    root = math.sqrt(disc)
    qq = -0.5 * (a1 + root if a1 >= 0.0 else a1 - root)
    lam1 = qq / a2
    lam2 = a0 / qq if qq != 0.0 else lam1
    return 2, p0t + lam1 * qt, p0s + lam1 * qs, p0t + lam2 * qt, p0s + lam2 * qs


@njit(cache=True)
def _on_conic(t, s, qa, qb, qc, qd, qe, qf):  # type: ignore[no-untyped-def]
    """True when ``Q(t, s)`` is zero up to round-off (a root that really is on the conic)."""
    size = (abs(qa) * t * t + 2.0 * abs(qb * t * s) + abs(qc) * s * s + 2.0 * abs(qd * t)
            + 2.0 * abs(qe * s) + abs(qf))
    return abs(_q(t, s, qa, qb, qc, qd, qe, qf)) <= _EPS_Q + _REL_Q * size


@njit(cache=True)
def swept_interval(  # type: ignore[no-untyped-def]
    qa, qb, qc, qd, qe, qf, zw, zu, zd, zlo, zhi, buf
):
    """Interval ``[tmin, tmax]`` of a ray inside a swept primitive (see module doc).

    Parameters are the coefficients of ``Q(t, s) = qa t^2 + 2 qb t s + qc s^2 + 2 qd t
    + 2 qe s + qf`` and of the tool-frame height ``z = zw + zu t - zd s``; ``buf`` is
    unused (kept for callers of the earlier signature). Returns ``(tmin, tmax)``;
    ``tmin > tmax`` when empty.
    """
    return swept_interval_scalar(qa, qb, qc, qd, qe, qf, zw, zu, zd, zlo, zhi)


@njit(cache=True)
def swept_interval_scalar(  # type: ignore[no-untyped-def]
    qa, qb, qc, qd, qe, qf, zw, zu, zd, zlo, zhi
):
    """``swept_interval`` without the scratch array (scalars only: no reference
    counting when called from a compiled loop)."""
    tmin = np.inf
    tmax = -np.inf
    # (1) corners of the slab lines with s = 0 and s = 1
    if abs(zu) > _TINY:
        for s in (0.0, 1.0):
            for zc in (zlo, zhi):
                t = (zc - zw + zd * s) / zu
                if _q(t, s, qa, qb, qc, qd, qe, qf) <= _EPS_Q:
                    if _feasible(t, s, zw, zu, zd, zlo, zhi):
                        tmin = min(tmin, t)
                        tmax = max(tmax, t)
    # (2) each boundary line against the conic, (3) the tangency line dQ/ds = 0
    for which in range(5):
        if which == 0:
            ct, cs, c0 = 0.0, 1.0, 0.0
        elif which == 1:
            ct, cs, c0 = 0.0, 1.0, -1.0
        elif which == 2:
            ct, cs, c0 = zu, -zd, zw - zlo
        elif which == 3:
            ct, cs, c0 = zu, -zd, zw - zhi
        else:
            ct, cs, c0 = qb, qc, qe
        n, t1, s1, t2, s2 = _line_roots(ct, cs, c0, qa, qb, qc, qd, qe, qf)
        for m in range(n):
            t = t1 if m == 0 else t2
            s = s1 if m == 0 else s2
            if _feasible(t, s, zw, zu, zd, zlo, zhi) and _on_conic(t, s, qa, qb, qc, qd, qe, qf):
                tmin = min(tmin, t)
                tmax = max(tmax, t)
    return tmin, tmax


@njit(cache=True)
def _subtract(lo, hi, lom, him, start, count, cap, used, r, a, b, move):  # type: ignore[no-untyped-def]
    """Remove ``[a, b]`` from ray ``r``. Returns removed length, or -1 when the pool is full."""
    n = count[r]
    base = start[r]
    i = 0
    while i < n and hi[base + i] <= a:
        i += 1
    j = i
    while j < n and lo[base + j] < b:
        j += 1
    if i == j:
        return 0.0
    removed = 0.0
    for m in range(i, j):
        removed += min(hi[base + m], b) - max(lo[base + m], a)
    keep_left = lo[base + i] < a - MIN_PIECE
    keep_right = hi[base + j - 1] > b + MIN_PIECE
    left_lo, left_lom = lo[base + i], lom[base + i]
    right_hi, right_him = hi[base + j - 1], him[base + j - 1]
    new_k = int(keep_left) + int(keep_right)
    delta = new_k - (j - i)
    if n + delta > cap[r]:
        new_cap = 2 * cap[r] + 2
        if used[0] + new_cap > lo.shape[0]:
            return -1.0
        nb = used[0]
        for m in range(n):
            lo[nb + m] = lo[base + m]
            hi[nb + m] = hi[base + m]
            lom[nb + m] = lom[base + m]
            him[nb + m] = him[base + m]
        used[0] += new_cap
        start[r] = nb
        cap[r] = new_cap
        base = nb
    if delta > 0:
        for m in range(n - 1, j - 1, -1):
            lo[base + m + delta] = lo[base + m]
            hi[base + m + delta] = hi[base + m]
            lom[base + m + delta] = lom[base + m]
            him[base + m + delta] = him[base + m]
    elif delta < 0:
        for m in range(j, n):
            lo[base + m + delta] = lo[base + m]
            hi[base + m + delta] = hi[base + m]
            lom[base + m + delta] = lom[base + m]
            him[base + m + delta] = him[base + m]
    w = base + i
    if keep_left:
        lo[w] = left_lo
        lom[w] = left_lom
        hi[w] = a
        him[w] = move
        w += 1
    if keep_right:
        lo[w] = b
        lom[w] = move
        hi[w] = right_hi
        him[w] = right_him
    count[r] = n + delta
    return removed


@njit(cache=True)
def _seg_dist2(px, py, ax, ay, bx, by):  # type: ignore[no-untyped-def]
    """Squared distance from point p to segment a-b (2D)."""
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = 0.0
    if ll > 0.0:
        t = min(1.0, max(0.0, ((px - ax) * ex + (py - ay) * ey) / ll))
    dx = px - ax - t * ex
    dy = py - ay - t * ey
    return dx * dx + dy * dy


@njit(cache=True)
def _near_parallelogram(px, py, cx, cy, e1x, e1y, e2x, e2y, reach):  # type: ignore[no-untyped-def]
    """True when p is within ``reach`` of the parallelogram c + u e1 + v e2 (u, v in [0, 1])."""
    det = e1x * e2y - e1y * e2x
    rx = px - cx
    ry = py - cy
    if abs(det) > 1e-12:
        u = (rx * e2y - ry * e2x) / det
        v = (e1x * ry - e1y * rx) / det
        if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0:
            return True
    r2 = reach * reach
    if _seg_dist2(px, py, cx, cy, cx + e1x, cy + e1y) <= r2:
        return True
    if _seg_dist2(px, py, cx, cy, cx + e2x, cy + e2y) <= r2:
        return True
    if _seg_dist2(px, py, cx + e1x, cy + e1y, cx + e1x + e2x, cy + e1y + e2y) <= r2:
        return True
    return _seg_dist2(px, py, cx + e2x, cy + e2y, cx + e1x + e2x, cy + e1y + e2y) <= r2


@njit(cache=True)
def _overlap(lo, hi, start, count, r, a, b):  # type: ignore[no-untyped-def]
    base = start[r]
    total = 0.0
    for m in range(count[r]):
        x0 = max(lo[base + m], a)
        x1 = min(hi[base + m], b)
        if x1 > x0:
            total += x1 - x0
    return total


@njit(cache=True)
def sweep_moves(  # type: ignore[no-untyped-def]
    lo, hi, lom, him, start, count, cap, used,
    k, origin, shape, h,
    tile_lo, tile_hi, tile,
    tips, moves, axes, move_ids, prims, cuts, strides, masks, first, stats,
):
    """Sweep a batch of straight fixed-axis moves through one dexel grid (reference
    implementation; ``Stock.sweep`` uses ``cam.verify.sweep.sweep_grid``).

    Parameters
    ----------
    lo, hi : (P,) float64
        Interval pool of the grid, ``lom``/``him`` (P,) int32 the move ids of the ends.
    start : (R,) int64, count, cap : (R,) int32, used : (1,) int64
        Ray bookkeeping (see module doc).
    k : int
        Ray direction (0, 1, 2).
    origin : (2,) float64
        World coordinates of the grid corner on axes ``(k+1) % 3`` and ``(k+2) % 3``.
    shape : (2,) int64
        Rays along those axes.
    h : float
        Grid pitch, mm.
    tile_lo, tile_hi : (TI, TJ) float64
        Lowest start and highest end of the intervals of each ``tile`` x ``tile`` block
        of rays (``inf``/``-inf`` when empty): a conservative bound used to skip blocks
        (material only disappears, so a bound taken before the sweep stays valid).
    tile : int
        Rays per tile side.
    tips, moves, axes : (M, 3) float64
        Start tip, tip displacement and unit axis of each move.
    move_ids : (M,) int32
        Move index recorded at the interval ends a move creates.
    prims : (p, 6) float64
        Primitives (``toolshape.PRIMITIVE_COLUMNS``).
    cuts : (p,) bool
        True: the primitive removes material; False: only measure its overlap.
    strides : (p,) int64
        Visit every ``stride``-th ray along both grid axes (1 for cutting primitives;
        a coarser lattice for the shank/holder probe).
    masks : (M,) int64
        The primitives each move sweeps: bit ``p`` for primitive ``p``
        (``Stock.sweep``: a block's primitives of a level along their own, longer
        sub-moves).
    first : int
        First move of the batch to process (resume after a pool overflow).
    stats : (M, 4) float64
        Accumulated per move: cut length sum, longest cut, overlap sum, longest overlap.

    Returns
    -------
    int
        -1 when done, else the move at which the pool overflowed (grow and resume).
    """
    ia = (k + 1) % 3
    ja = (k + 2) % 3
    ni = shape[0]
    nj = shape[1]
    bmin = np.empty(3)
    bmax = np.empty(3)
    for mv in range(first, tips.shape[0]):
        ax0, ax1, ax2 = axes[mv, 0], axes[mv, 1], axes[mv, 2]
        d0, d1, d2 = moves[mv, 0], moves[mv, 1], moves[mv, 2]
        t0x, t0y, t0z = tips[mv, 0], tips[mv, 1], tips[mv, 2]
        zu = axes[mv, k]
        zd = ax0 * d0 + ax1 * d1 + ax2 * d2
        uu = 1.0 - zu * zu
        dk = moves[mv, k]
        ud = dk - zu * zd
        dd = d0 * d0 + d1 * d1 + d2 * d2 - zd * zd
        for p in range(prims.shape[0]):
            if not (masks[mv] >> p) & 1:
                continue
            alpha, beta, gamma = prims[p, 0], prims[p, 1], prims[p, 2]
            zlo, zhi, rmax = prims[p, 3], prims[p, 4], prims[p, 5]
            # bounding box of the swept primitive
            for c in range(3):
                e = rmax * math.sqrt(max(0.0, 1.0 - axes[mv, c] ** 2))
                v0 = tips[mv, c] + zlo * axes[mv, c]
                v1 = tips[mv, c] + zhi * axes[mv, c]
                lo_c = min(v0, v1, v0 + moves[mv, c], v1 + moves[mv, c])
                hi_c = max(v0, v1, v0 + moves[mv, c], v1 + moves[mv, c])
                bmin[c] = lo_c - e - 1e-9
                bmax[c] = hi_c + e + 1e-9
            i0 = max(0, int(math.floor((bmin[ia] - origin[0]) / h - 0.5)))
            i1 = min(ni - 1, int(math.ceil((bmax[ia] - origin[0]) / h - 0.5)))
            j0 = max(0, int(math.floor((bmin[ja] - origin[1]) / h - 0.5)))
            j1 = min(nj - 1, int(math.ceil((bmax[ja] - origin[1]) / h - 0.5)))
            # projection of the swept axis segment on the grid plane: a parallelogram
            pcx = tips[mv, ia] + zlo * axes[mv, ia]
            pcy = tips[mv, ja] + zlo * axes[mv, ja]
            pe1x = moves[mv, ia]
            pe1y = moves[mv, ja]
            pe2x = (zhi - zlo) * axes[mv, ia]
            pe2y = (zhi - zlo) * axes[mv, ja]
            step = strides[p]
            qa = uu + alpha * zu * zu
            qb = -ud - alpha * zu * zd
            qc = dd + alpha * zd * zd
            for ti in range(i0 // tile, i1 // tile + 1):
                for tj in range(j0 // tile, j1 // tile + 1):
                    if tile_lo[ti, tj] >= bmax[k] or tile_hi[ti, tj] <= bmin[k]:
                        continue
                    ia0 = max(i0, ti * tile)
                    ja0 = max(j0, tj * tile)
                    ia0 += (-ia0) % step
                    ja0 += (-ja0) % step
                    for ii in range(ia0, min(i1, ti * tile + tile - 1) + 1, step):
                        ci = origin[0] + (ii + 0.5) * h
                        for jj in range(ja0, min(j1, tj * tile + tile - 1) + 1, step):
                            r = ii * nj + jj
                            n = count[r]
                            if n == 0:
                                continue
                            base = start[r]
                            if lo[base] >= bmax[k] or hi[base + n - 1] <= bmin[k]:
                                continue
                            cj = origin[1] + (jj + 0.5) * h
                            if not _near_parallelogram(
                                ci, cj, pcx, pcy, pe1x, pe1y, pe2x, pe2y, rmax + 1e-9
                            ):
                                continue
                            # w = o - tip0, o on the ray at coordinate 0 along k
                            w0 = (ci if ia == 0 else (cj if ja == 0 else 0.0)) - t0x
                            w1 = (ci if ia == 1 else (cj if ja == 1 else 0.0)) - t0y
                            w2 = (ci if ia == 2 else (cj if ja == 2 else 0.0)) - t0z
                            zw = ax0 * w0 + ax1 * w1 + ax2 * w2
                            wk = w0 if k == 0 else (w1 if k == 1 else w2)
                            wu = wk - zw * zu
                            wd = w0 * d0 + w1 * d1 + w2 * d2 - zw * zd
                            ww = w0 * w0 + w1 * w1 + w2 * w2 - zw * zw
                            qd = wu + alpha * zw * zu + 0.5 * beta * zu
                            qe = -wd - alpha * zw * zd - 0.5 * beta * zd
                            qf = ww + alpha * zw * zw + beta * zw + gamma
                            ta, tb = swept_interval_scalar(
                                qa, qb, qc, qd, qe, qf, zw, zu, zd, zlo, zhi
                            )
                            if not tb > ta:
                                continue
                            if cuts[p]:
                                got = _subtract(lo, hi, lom, him, start, count, cap, used, r,
                                                ta, tb, move_ids[mv])
                                if got < 0.0:
                                    return mv
                                stats[mv, 0] += got
                                stats[mv, 1] = max(stats[mv, 1], got)
                            else:
                                got = _overlap(lo, hi, start, count, r, ta, tb)
                                stats[mv, 2] += got
                                stats[mv, 3] = max(stats[mv, 3], got)
    return -1


@njit(cache=True, nogil=True)
def tile_bounds(lo, hi, start, count, shape, tile):  # type: ignore[no-untyped-def]
    """Per ``tile`` x ``tile`` block of rays: lowest start and highest end of material."""
    nti = (shape[0] + tile - 1) // tile
    ntj = (shape[1] + tile - 1) // tile
    t_lo = np.full((nti, ntj), np.inf)
    t_hi = np.full((nti, ntj), -np.inf)
    nj = shape[1]
    for r in range(count.shape[0]):
        n = count[r]
        if n == 0:
            continue
        ti = (r // nj) // tile
        tj = (r % nj) // tile
        t_lo[ti, tj] = min(t_lo[ti, tj], lo[start[r]])
        t_hi[ti, tj] = max(t_hi[ti, tj], hi[start[r] + n - 1])
    return t_lo, t_hi
