"""The batched dexel sweep: straight fixed-axis moves through one grid, compiled.

One call of ``sweep_grid`` takes a whole batch of moves (no Python per move). Per
move and tool primitive it visits only rays that can meet the sweep and that still
hold material there, in three filters of rising cost:

1. **footprint**: every swept primitive lies in a capsule (points within ``rho`` of a
   segment): a full sphere's sweep *is* the capsule around the travelled segment of
   its centre; any other primitive lies within ``rmax`` of the parallelogram its axis
   sweeps, hence in a capsule around the axis at the mid move (``rmax + |d|/2``) or
   around the move at the mid axis (``hypot(rmax, (zhi - zlo)/2)``), the thinner of
   the two (``footprint.capsule``), clipped by the swept primitive's bounding box
   (``footprint.box_side``). Per band of rows (one tile row), only the tiles whose
   material range meets the capsule's range over that tile (``footprint.tile_columns``);
   per grid row, ``interval.stadium_row`` gives the span of rays inside the capsule's
   projection, and runs of a tile's width whose material the capsule's range over
   them cannot meet (``footprint.piece_misses``) are skipped;
2. **material**: the capsule's interval on the ray (exact for a sphere) against the
   ray's material range and its first gap (both kept per ray, up to date): no
   overlap, no more work (the early-out for rays whose material is already gone
   there, or lies on both sides of the cut channel the tool moves in);
3. **exact interval**: for primitives other than a full ball, the end-pose closed
   form (``interval.endpoint_row``) or the normal-ray closed form
   (``interval.normal_row``) in one vectorised loop over the rays of a row that passed
   step 2 (gathered first); a ray along a cylinder's axis
   and the rays those forms decline get ``parallel_cylinder_interval`` or
   ``kernels.swept_interval`` (the general path and accuracy reference), after the
   swept slab bound and the ray's own intervals have been checked.

The per-ray material and gap ranges and the tiles' ranges are kept with the grid
(``dexel.SweepIndex``) from one call to the next. Rows are taken in bands of
``_BAND``: each band goes through all the moves of the
batch before the next, so its rays stay in cache from one move to the next; every
ray still sees the moves, and within a move the primitives, in order, so the result
is that of the move-by-move sweep.

Semantics are those of the per-primitive sweep in ``kernels``: moves in order, and
within a move the cutting primitives before the body probes on each ray; per move
the removed length, the longest cut of the cutter along one ray (the cutter's
primitives together), the overlap sum and the longest overlap of one body primitive.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cam.verify.dexel import TILE
from cam.verify.footprint import box_side, capsule, grid_rows, piece_misses, tile_columns
from cam.verify.interval import (
    capsule_row,
    endpoint_interval,
    endpoint_row,
    normal_interval,
    normal_row,
    parallel_cylinder_interval,
    stadium_row,
)
from cam.verify.kernels import MIN_PIECE, _subtract, swept_interval_scalar

_PAR = 1e-12
_GUARD = 1e-9  # mm added to every bound
_BAND = 16  # grid rows swept through all the moves of a batch at a time (divides TILE)


@njit(cache=True, inline="always")
def _add_counts(counters, c0, c1, c2, c3, c4, c5):  # type: ignore[no-untyped-def]
    counters[0] += c0
    counters[1] += c1
    counters[2] += c2
    counters[3] += c3
    counters[4] += c4
    counters[5] += c5


@njit(cache=True, inline="always")
def _move_frame(tips, moves, axes, mv, ia, ja, k, tipg, dg, ag):  # type: ignore[no-untyped-def]
    """Tip, displacement and axis of move ``mv`` in the grid frame ``(ia, ja, k)``."""
    tipg[0] = tips[mv, ia]
    tipg[1] = tips[mv, ja]
    tipg[2] = tips[mv, k]
    dg[0] = moves[mv, ia]
    dg[1] = moves[mv, ja]
    dg[2] = moves[mv, k]
    ag[0] = axes[mv, ia]
    ag[1] = axes[mv, ja]
    ag[2] = axes[mv, k]


@njit(cache=True, nogil=True, error_model="numpy")
def sweep_grid(  # type: ignore[no-untyped-def]
    lo, hi, lom, him, start, count, cap, used,
    k, origin, shape, h,
    tile_lo, tile_hi, tile_dirty, tile,
    tips, moves, axes, move_ids, prims, cuts, strides, masks, first, stats, acc, touched,
    counters,
    mat_lo, mat_hi, gap_lo, gap_hi,
):
    """Sweep moves ``first..`` through one dexel grid (arguments as in
    ``kernels.sweep_moves``).

    ``counters`` (6,) int64 accumulates, over all moves and primitives: rays in the
    footprint spans; rays whose interval (the exact one where a row form gave it, else
    the capsule's) meets their material outside the first gap; of those (primitives
    other than a full ball) rays that got an exact interval; exact intervals by a
    closed form; by the general ``swept_interval``; rays that lost material or
    overlap a body primitive.

    ``mat_lo``, ``mat_hi``, ``gap_lo``, ``gap_hi`` (R,) float64: ``material_range`` of
    the grid, kept up to date by the call (contiguous per row, so the material test
    vectorises). ``tile_lo``, ``tile_hi``: the tiles' material range, a bound (stale
    is conservative); ``tile_dirty`` flags the tiles whose rays the call changed
    (``dexel.SweepIndex``). ``tile`` must be ``dexel.TILE`` (compiled in as a constant).

    ``acc`` (R,) float64 zeros and ``touched`` (R + 1,) int64 (``touched[0]``: count)
    hold the per-ray cut of the move in progress, so a move resumed after a pool
    overflow still reports its longest cut; both are left clean when the call ends.

    ``first``: where to start, 0 or the value returned by the call that overflowed.
    Returns -1 when done, else the position (band of rows and move) at which the pool
    overflowed: grow it and call again with that as ``first``.
    """
    if tile != TILE:
        raise ValueError("sweep_grid: tile must be dexel.TILE")
    tile = TILE  # a compile-time constant: the divisions by it become shifts
    ia = (k + 1) % 3
    ja = (k + 2) % 3
    ni = shape[0]
    nj = shape[1]
    tipg = np.empty(3)  # grid frame: (ia, ja, k)
    dg = np.empty(3)
    ag = np.empty(3)
    row_a = np.empty(max(shape[0], shape[1]) + 1)
    row_b = np.empty(max(shape[0], shape[1]) + 1)
    row_c = np.empty(max(shape[0], shape[1]) + 1)
    row_d = np.empty(max(shape[0], shape[1]) + 1)
    row_ok = np.zeros(max(shape[0], shape[1]) + 1, np.bool_)
    row_sel = np.zeros(max(shape[0], shape[1]) + 1, np.int64)
    n_c0 = n_c1 = n_c2 = n_c3 = n_c4 = n_c5 = 0
    n_moves = tips.shape[0]
    if n_moves == 0:
        return -1
    # the rows each move can reach (all its primitives)
    reach_lo = np.full(n_moves, ni, np.int64)
    reach_hi = np.full(n_moves, -1, np.int64)
    for mv in range(n_moves):
        _move_frame(tips, moves, axes, mv, ia, ja, k, tipg, dg, ag)
        for p in range(prims.shape[0]):
            if not (masks[mv] >> p) & 1:
                continue
            p0x, p0y, p0z, ux, uy, uz, length, rho, exact = capsule(
                tipg[0], tipg[1], tipg[2], dg[0], dg[1], dg[2], ag[0], ag[1], ag[2],
                prims[p, 0], prims[p, 1], prims[p, 2], prims[p, 3], prims[p, 4], prims[p, 5])
            i0, i1 = grid_rows(p0x, p0x + length * ux, rho, origin[0], h, ni)
            reach_lo[mv] = min(reach_lo[mv], i0)
            reach_hi[mv] = max(reach_hi[mv], i1)
    # bands of rows, each through all the moves in order: a band's rays stay in cache
    # from one move to the next; every ray still sees the moves in order
    for band in range(first // n_moves, (ni + _BAND - 1) // _BAND):
        b_lo = band * _BAND
        b_hi = min(ni - 1, b_lo + _BAND - 1)
        mv0 = first % n_moves if band == first // n_moves else 0
        for mv in range(mv0, n_moves):
            if reach_hi[mv] < b_lo or reach_lo[mv] > b_hi:
                continue
            _move_frame(tips, moves, axes, mv, ia, ja, k, tipg, dg, ag)
            removed = 0.0  # this move's sums in this band (into stats at its end)
            overlap = 0.0
            overlap_max = 0.0
            zu = ag[2]
            zd = ag[0] * dg[0] + ag[1] * dg[1] + ag[2] * dg[2]
            uu = 1.0 - zu * zu
            ud = dg[2] - zu * zd
            dd = dg[0] * dg[0] + dg[1] * dg[1] + dg[2] * dg[2] - zd * zd
            for p in range(prims.shape[0]):
                if not (masks[mv] >> p) & 1:
                    continue
                alpha, beta, gamma = prims[p, 0], prims[p, 1], prims[p, 2]
                zlo, zhi, rmax = prims[p, 3], prims[p, 4], prims[p, 5]
                cutting = cuts[p]
                step = strides[p]
                p0x, p0y, p0z, ux, uy, uz, length, rho, exact = capsule(
                    tipg[0], tipg[1], tipg[2], dg[0], dg[1], dg[2], ag[0], ag[1], ag[2],
                    alpha, beta, gamma, zlo, zhi, rmax)
                rho2 = rho * rho
                p1x = p0x + length * ux
                p1y = p0y + length * uy
                # the swept primitive's bounding box clips the capsule (a primitive
                # not much longer than wide, or a tall one cut short by the stock)
                bxlo, bxhi = box_side(tipg[0], dg[0], ag[0], zlo, zhi, rmax)
                bylo, byhi = box_side(tipg[1], dg[1], ag[1], zlo, zhi, rmax)
                bzlo, bzhi = box_side(tipg[2], dg[2], ag[2], zlo, zhi, rmax)
                kmin = max(min(p0z, p0z + length * uz) - rho, bzlo)
                kmax = min(max(p0z, p0z + length * uz) + rho, bzhi)
                i0, i1 = grid_rows(p0x, p1x, rho, origin[0], h, ni)
                i0 = max(i0, b_lo, int(math.ceil((bxlo - origin[0]) / h - 0.5)))
                i1 = min(i1, b_hi, int(math.floor((bxhi - origin[0]) / h - 0.5)))
                jb0 = max(0, int(math.ceil((bylo - origin[1]) / h - 0.5)))
                jb1 = min(nj - 1, int(math.floor((byhi - origin[1]) / h - 0.5)))
                i0 += (-i0) % step  # probed rows: multiples of the stride
                if i0 > i1:
                    continue
                # the band lies in one tile row: its tiles the capsule can meet
                jb0, jb1 = tile_columns(b_lo // tile, i0, i1, jb0, jb1, tile, tile_lo,
                                        tile_hi, origin[0], origin[1], h, p0x, p0y, p0z,
                                        ux, uy, uz, length, rho, kmin, kmax)
                if jb0 > jb1:
                    continue
                qa = uu + alpha * zu * zu
                qb = -ud - alpha * zu * zd
                qc = dd + alpha * zd * zd
                parallel = alpha == 0.0 and uu < _PAR
                normal = abs(zu) <= 1e-14
                # end-pose intervals of a whole row at once (vectorised)
                rowwise = not exact and not parallel and (normal or qa > 1e-9)
                for ii in range(i0, i1 + 1, step):
                    ci = origin[0] + (ii + 0.5) * h
                    ylo, yhi = stadium_row(ci, p0x, p0y, p1x, p1y, rho)
                    if not ylo <= yhi:
                        continue
                    j0 = max(jb0, int(math.ceil((ylo - origin[1]) / h - 0.5)))
                    j1 = min(jb1, int(math.floor((yhi - origin[1]) / h - 0.5)))
                    j0 += (-j0) % step
                    ti = ii // tile
                    # the span in pieces of consecutive tiles where the capsule's
                    # range along the rays can meet their material
                    j_end = j1
                    jn = j0
                    while jn <= j_end:
                        j0 = jn
                        while j0 <= j_end:
                            je = min(j_end, (j0 // tile + 1) * tile - 1)
                            if not piece_misses(ci, j0, je, ii * nj, tile_lo[ti, j0 // tile],
                                                 tile_hi[ti, j0 // tile], mat_lo, mat_hi,
                                                 origin[1], h, p0x, p0y, p0z, ux, uy, uz,
                                                 length, rho, kmin, kmax):
                                break
                            j0 = je + 1
                            j0 += (-j0) % step
                        if j0 > j_end:
                            break
                        j1 = min(j_end, (j0 // tile + 1) * tile - 1)
                        while j1 < j_end:
                            je = min(j_end, ((j1 + 1) // tile + 1) * tile - 1)
                            if piece_misses(ci, j1 + 1, je, ii * nj,
                                             tile_lo[ti, (j1 + 1) // tile],
                                             tile_hi[ti, (j1 + 1) // tile], mat_lo, mat_hi,
                                             origin[1], h, p0x, p0y, p0z, ux, uy, uz,
                                             length, rho, kmin, kmax):
                                break
                            j1 = je
                        jn = j1 + 1
                        jn += (-jn) % step
                        mx = ci - p0x
                        w0 = ci - tipg[0]
                        nspan = (j1 - j0) // step + 1
                        cj0 = origin[1] + (j0 + 0.5) * h
                        capsule_row(row_a, row_b, nspan, mx, cj0 - p0y, step * h, -p0z,
                                    ux, uy, uz, length, rho2)
                        n_c0 += nspan
                        r0 = ii * nj + j0
                        # for the row forms, the rays whose capsule interval (clipped by
                        # the box) meets their material outside the first gap; an exact
                        # interval lies inside it, so no other ray can change: only these
                        # get the exact form and the per-ray work (other primitives test
                        # each ray of the span in the per-ray loop)
                        n_sel = 0
                        if rowwise:
                            for m in range(nspan):
                                r = r0 + m * step
                                ta = max(row_a[m], kmin)
                                tb = min(row_b[m], kmax)
                                row_sel[n_sel] = m
                                n_sel += (tb > ta and ta < mat_hi[r] and tb > mat_lo[r]
                                          and (ta < gap_lo[r] or tb > gap_hi[r]))
                        else:
                            for m in range(nspan):
                                row_sel[m] = m
                            n_sel = nspan
                        if n_sel == 0:
                            continue
                        jc_lo = nspan  # the span's first and last changed ray
                        jc_hi = -1
                        if rowwise and normal:
                            normal_row(row_c, row_d, row_ok, row_sel, n_sel, cj0, step, h,
                                       w0, tipg[1], -tipg[2], ag[0], ag[1], ag[2], dg[0], dg[1],
                                       dg[2], zu, zd, alpha, beta, gamma, qa, qb, qc, zlo, zhi)
                        elif rowwise:
                            endpoint_row(row_c, row_d, row_ok, row_sel, n_sel, cj0, step,
                                         h, w0, tipg[1], -tipg[2], ag[0], ag[1], ag[2], dg[0],
                                         dg[1], dg[2], zu, zd, alpha, beta, gamma, qa, qb, qc,
                                         zlo, zhi)
                        for q in range(n_sel):
                            m = row_sel[q]
                            known = rowwise and row_ok[q]
                            ta = row_c[q] if known else row_a[m]
                            tb = row_d[q] if known else row_b[m]
                            if not (known or exact):  # a bound: the box clips it
                                ta = max(ta, kmin)
                                tb = min(tb, kmax)
                            r = r0 + m * step
                            mlo = mat_lo[r]
                            mhi = mat_hi[r]
                            # no material there, or all of it in the ray's first gap (the
                            # test of the selection, again for an exact interval)
                            if (known or not rowwise) and not (tb > ta and ta < mhi and tb > mlo
                                                             and (ta < gap_lo[r]
                                                                  or tb > gap_hi[r])):
                                continue
                            n_c1 += 1
                            if known:
                                n_c2 += 1
                                n_c3 += 1
                            elif not exact:
                                cj = cj0 + m * step * h
                                w1 = cj - tipg[1]
                                w2 = -tipg[2]
                                zw = ag[0] * w0 + ag[1] * w1 + ag[2] * w2
                                # the swept slab along the ray
                                if abs(zu) > 1e-14:
                                    za = (zlo - zw + min(0.0, zd)) / zu
                                    zb = (zhi - zw + max(0.0, zd)) / zu
                                    sa = max(ta, min(za, zb) - _GUARD)
                                    sb = min(tb, max(za, zb) + _GUARD)
                                    if not (sb > sa and sa < mhi and sb > mlo):
                                        continue
                                elif zw - max(0.0, zd) > zhi or zw - min(0.0, zd) < zlo:
                                    continue
                                else:
                                    sa = ta
                                    sb = tb
                                # the ray's intervals against that bound (rays with material
                                # on both sides of a cut channel pass the range test)
                                base = start[r]
                                n = count[r]
                                i = 0
                                while i < n and hi[base + i] <= sa:
                                    i += 1
                                if i == n or lo[base + i] >= sb:
                                    continue
                                n_c2 += 1
                                wu = w2 - zw * zu
                                wd = w0 * dg[0] + w1 * dg[1] + w2 * dg[2] - zw * zd
                                ww = w0 * w0 + w1 * w1 + w2 * w2 - zw * zw
                                qd = wu + alpha * zw * zu + 0.5 * beta * zu
                                qe = -wd - alpha * zw * zd - 0.5 * beta * zd
                                qf = ww + alpha * zw * zw + beta * zw + gamma
                                done = False
                                if parallel:
                                    ta, tb = parallel_cylinder_interval(qc, qe, qf, zw, zu, zd,
                                                                        zlo, zhi)
                                    done = True
                                elif normal and not rowwise:
                                    done, ta, tb = normal_interval(qa, qb, qc, qd, qe, qf, zw, zd,
                                                                   zlo, zhi, alpha)
                                if not done and qa > 1e-9 and not rowwise:
                                    done, ta, tb = endpoint_interval(qa, qb, qc, qd, qe, qf, zw,
                                                                     zu, zd, zlo, zhi)
                                if done:
                                    n_c3 += 1
                                else:
                                    n_c4 += 1
                                    ta, tb = swept_interval_scalar(qa, qb, qc, qd, qe, qf, zw, zu,
                                                                   zd, zlo, zhi)
                                if not (tb > ta and ta < mhi and tb > mlo):
                                    continue
                            base = start[r]
                            n = count[r]
                            if not cutting:
                                got = 0.0
                                for q in range(n):
                                    x0 = max(lo[base + q], ta)
                                    x1 = min(hi[base + q], tb)
                                    if x1 > x0:
                                        got += x1 - x0
                                n_c5 += 1 if got > 0.0 else 0
                                overlap += got
                                overlap_max = max(overlap_max, got)
                                continue
                            # the common subtractions written out here: a helper taking the
                            # pool arrays costs two atomic reference-count updates per array
                            # and call, more than the subtraction itself
                            mid = move_ids[mv]
                            i = 0
                            while i < n and hi[base + i] <= ta:
                                i += 1
                            if i == n or lo[base + i] >= tb:
                                continue
                            j = i
                            got = 0.0
                            while j < n and lo[base + j] < tb:
                                got += min(hi[base + j], tb) - max(lo[base + j], ta)
                                j += 1
                            left_lo = lo[base + i]
                            left_lom = lom[base + i]
                            right_hi = hi[base + j - 1]
                            right_him = him[base + j - 1]
                            keep_left = left_lo < ta - MIN_PIECE
                            keep_right = right_hi > tb + MIN_PIECE
                            delta = int(keep_left) + int(keep_right) - (j - i)
                            if delta == 0 or (j == n and (delta < 0 or n < cap[r])):
                                # nothing to shift: rewrite the met intervals in place
                                w = base + i
                                if keep_left:
                                    lo[w] = left_lo
                                    lom[w] = left_lom
                                    hi[w] = ta
                                    him[w] = mid
                                    w += 1
                                if keep_right:
                                    lo[w] = tb
                                    lom[w] = mid
                                    hi[w] = right_hi
                                    him[w] = right_him
                                count[r] = n + delta
                            else:
                                got = -1.0
                            if got < 0.0:
                                got = _subtract(lo, hi, lom, him, start, count, cap, used, r,
                                                ta, tb, mid)
                                if got < 0.0:
                                    if jc_hi >= 0:
                                        for tj in range((j0 + jc_lo * step) // tile,
                                                        (j0 + jc_hi * step) // tile + 1):
                                            tile_dirty[ti, tj] = True
                                    _add_counts(counters, n_c0, n_c1, n_c2, n_c3, n_c4, n_c5)
                                    stats[mv, 0] += removed
                                    stats[mv, 2] += overlap
                                    stats[mv, 3] = max(stats[mv, 3], overlap_max)
                                    return band * n_moves + mv
                                base = start[r]
                            n = count[r]
                            jc_lo = min(jc_lo, m)
                            jc_hi = max(jc_hi, m)
                            mat_lo[r] = lo[base] if n > 0 else np.inf
                            mat_hi[r] = hi[base + n - 1] if n > 0 else -np.inf
                            gap_lo[r] = hi[base] if n > 1 else np.inf
                            gap_hi[r] = lo[base + 1] if n > 1 else -np.inf
                            if got > 0.0:
                                n_c5 += 1
                                removed += got
                                if acc[r] == 0.0:
                                    touched[0] += 1
                                    touched[touched[0]] = r
                                acc[r] += got
                        # the tiles the span changed (one division a span, not a ray)
                        if jc_hi >= 0:
                            for tj in range((j0 + jc_lo * step) // tile,
                                            (j0 + jc_hi * step) // tile + 1):
                                tile_dirty[ti, tj] = True
            stats[mv, 0] += removed
            stats[mv, 2] += overlap
            stats[mv, 3] = max(stats[mv, 3], overlap_max)
            longest = stats[mv, 1]
            for m in range(1, touched[0] + 1):
                r = touched[m]
                longest = max(longest, acc[r])
                acc[r] = 0.0
            touched[0] = 0
            stats[mv, 1] = longest
    _add_counts(counters, n_c0, n_c1, n_c2, n_c3, n_c4, n_c5)
    return -1
