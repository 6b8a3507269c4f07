"""Closed forms of the ray interval of a swept primitive, faster than the general path.

``kernels.swept_interval`` is the general, exact path (every candidate point of the
conic section in the ``(t, s)`` plane) and the accuracy reference. The sweep engine
(``cam.verify.sweep``) tries these special forms first; each is exact (up to
round-off) in the cases it accepts and says so, otherwise the caller uses the general
path. ``tests/cam/test_verify_interval.py`` compares each with ``swept_interval``.

* ``capsule_interval``: a ray against the set of points within ``rho`` of a segment
  (a sphere swept along a straight move is exactly such a capsule).
* ``parallel_cylinder_interval``: a ray parallel to the axis of a swept cylinder
  (a vertical tool on the Z rays): an ``s`` range of one quadratic, then the slab.
* ``endpoint_interval``: any primitive whose section is bounded in ``t`` (``qa > 0``).
  The lower end of the ray interval at a fixed ``s`` is a convex function ``lo(s)``
  of ``s`` (the lower boundary of a convex set), the upper end ``hi(s)`` concave. So
  ``min lo`` over ``[0, 1]`` is ``lo(0)`` when ``lo`` does not fall at ``s = 0``,
  ``lo(1)`` when it does not rise at ``s = 1``; only otherwise (the extreme is inside
  the move: rays grazing the side of the sweep, a thin band for a short move) is the
  general path needed. The slopes come from implicit differentiation of the active
  constraint; at a tie of two constraints the slope of either one is conservative.
* ``normal_interval``: a ray normal to the tool axis (``zu = 0``: the X and Y rays of
  a vertical tool). The height along the axis no longer depends on ``t``, so the slab
  is an ``s`` range and the region in ``(t, s)`` is the conic cut by two lines
  ``s = const``: its extremes are the conic's roots on those two lines and the points
  of the conic on the tangency line ``dQ/ds = 0`` inside the range (three quadratics,
  no case of the general path can be missed).
* ``stadium_row``: the span of one grid row inside the projection of a capsule (a
  disc swept along a segment), so a move visits only the rays it can reach.
"""

from __future__ import annotations

import math

from numba import njit

_TINY = 1e-14
_PAR = 1e-12  # 1 - zu^2 below this: the ray is parallel to the tool axis


@njit(cache=True, inline="always")
def _quad_roots(a, b, c):  # type: ignore[no-untyped-def]
    """Roots of ``a t^2 + 2 b t + c`` (a > 0) as (lo, hi); (inf, -inf) when none."""
    disc = b * b - a * c
    if disc < 0.0:
        return math.inf, -math.inf
    root = math.sqrt(disc)
    q = -(b + root) if b >= 0.0 else -(b - root)
    if q == 0.0:
        return 0.0, 0.0
    r1 = q / a
    r2 = c / q
    return min(r1, r2), max(r1, r2)


@njit(cache=True)
def capsule_interval(mx, my, mz, ux, uy, uz, length, rho2):  # type: ignore[no-untyped-def]
    """Interval of the ray ``p(t) = (mx, my, mz + t)`` in the capsule of radius
    ``sqrt(rho2)`` around the segment from the origin along the unit vector ``u`` over
    ``length`` (grid frame: the ray runs along the third axis).

    Returns ``(tmin, tmax)``, ``tmin > tmax`` when the ray misses. The extremes lie on
    the end spheres or on the side cylinder where it projects inside the segment.
    """
    mm = mx * mx + my * my + mz * mz
    # sphere at the start: t^2 + 2 mz t + |m|^2 - rho2
    t0, t1 = _quad_roots(1.0, mz, mm - rho2)
    tmin, tmax = t0, t1
    if length > _TINY:
        # sphere at the end: m' = m - L u
        ex, ey, ez = mx - length * ux, my - length * uy, mz - length * uz
        s0, s1 = _quad_roots(1.0, ez, ex * ex + ey * ey + ez * ez - rho2)
        tmin = min(tmin, s0)
        tmax = max(tmax, s1)
        a = 1.0 - uz * uz
        if a > _TINY:
            mu = mx * ux + my * uy + mz * uz
            b = mz - mu * uz
            c = mm - mu * mu - rho2
            c0, c1 = _quad_roots(a, b, c)
            if c1 >= c0:
                # keep side roots whose foot lies on the segment
                f0 = mu + c0 * uz
                if 0.0 <= f0 <= length:
                    tmin = min(tmin, c0)
                    tmax = max(tmax, c0)
                f1 = mu + c1 * uz
                if 0.0 <= f1 <= length:
                    tmin = min(tmin, c1)
                    tmax = max(tmax, c1)
    return tmin, tmax


@njit(cache=True, fastmath=True, inline="always")
def capsule_row(ta, tb, count, mx, my0, dy, mz, ux, uy, uz, length, rho2):  # type: ignore[no-untyped-def]
    """``capsule_interval`` for ``count`` rays of one grid row (``my = my0 + j dy``),
    into ``ta``, ``tb``; branch-free so that the loop vectorises. Misses give
    ``ta > tb``."""
    a = 1.0 - uz * uz
    inv_a = 1.0 / a if a > _TINY else 0.0
    side = a > _TINY and length > _TINY
    ex = mx - length * ux
    ez = mz - length * uz
    for j in range(count):
        my = my0 + j * dy
        # start sphere: roots -mz -+ sqrt(rho2 - mx^2 - my^2)
        d0 = rho2 - mx * mx - my * my
        r0 = math.sqrt(max(d0, 0.0))
        lo = -mz - r0 if d0 >= 0.0 else math.inf
        hi = -mz + r0 if d0 >= 0.0 else -math.inf
        ey = my - length * uy
        d1 = rho2 - ex * ex - ey * ey
        r1 = math.sqrt(max(d1, 0.0))
        lo = min(lo, -ez - r1) if d1 >= 0.0 else lo
        hi = max(hi, -ez + r1) if d1 >= 0.0 else hi
        mu = mx * ux + my * uy + mz * uz
        b = mz - mu * uz
        c = mx * mx + my * my + mz * mz - mu * mu - rho2
        d2 = b * b - a * c
        r2 = math.sqrt(max(d2, 0.0))
        q = -(b + r2) if b >= 0.0 else -(b - r2)  # stable roots q / a and c / q
        qa_root = q * inv_a
        qc_root = c / q if q != 0.0 else qa_root
        c0 = min(qa_root, qc_root)
        c1 = max(qa_root, qc_root)
        f0 = mu + c0 * uz
        f1 = mu + c1 * uz
        ok0 = side and d2 >= 0.0 and f0 >= 0.0 and f0 <= length
        ok1 = side and d2 >= 0.0 and f1 >= 0.0 and f1 <= length
        lo = min(lo, c0) if ok0 else lo
        hi = max(hi, c0) if ok0 else hi
        lo = min(lo, c1) if ok1 else lo
        hi = max(hi, c1) if ok1 else hi
        ta[j] = lo
        tb[j] = hi


@njit(cache=True)
def parallel_cylinder_interval(  # type: ignore[no-untyped-def]
    qc, qe, qf, zw, zu, zd, zlo, zhi
):
    """Ray parallel to the axis of a swept cylinder (``qa = qb = qd = 0``).

    The ray meets the cylinder at ``s`` iff ``qc s^2 + 2 qe s + qf <= 0``; over that
    ``s`` range (within [0, 1]) the slab ``zlo <= zw + zu t - zd s <= zhi`` is a
    segment of ``t`` moving linearly with ``s``, so the ends are at the range's ends.
    """
    if qc > _TINY:
        s0, s1 = _quad_roots(qc, qe, qf)
    elif abs(qe) > _TINY:
        root = -qf / (2.0 * qe)
        s0, s1 = (-math.inf, root) if qe > 0.0 else (root, math.inf)
    else:
        s0, s1 = (-math.inf, math.inf) if qf <= 0.0 else (math.inf, -math.inf)
    s0 = max(s0, 0.0)
    s1 = min(s1, 1.0)
    if s1 < s0:
        return math.inf, -math.inf
    a0 = (zlo - zw + zd * s0) / zu
    b0 = (zhi - zw + zd * s0) / zu
    a1 = (zlo - zw + zd * s1) / zu
    b1 = (zhi - zw + zd * s1) / zu
    return min(a0, b0, a1, b1), max(a0, b0, a1, b1)


@njit(cache=True, inline="always")
def _static(s, qa, inv_qa, qb, qc, qd, qe, qf, zw, inv_zu, zd, zlo, zhi):  # type: ignore[no-untyped-def]
    """Ray interval of the primitive held at ``s``, with the slopes of its ends
    (``inv_qa = 1 / qa``; ``inv_zu = 1 / zu``, 0 when the ray is normal to the axis).

    Returns ``(ok, lo, hi, dlo, dhi)``; ``ok`` False when empty or tangent.
    """
    b = qb * s + qd
    c = (qc * s + 2.0 * qe) * s + qf
    disc = b * b - qa * c
    if disc <= 0.0:
        return False, 0.0, 0.0, 0.0, 0.0
    root = math.sqrt(disc)
    q = -(b + root) if b >= 0.0 else -(b - root)
    r1 = q * inv_qa
    r2 = c / q
    cl = min(r1, r2)
    ch = max(r1, r2)
    g = qc * s + qe
    inv_root = 1.0 / root
    dcl = (qb * cl + g) * inv_root  # dt/ds = -(dQ/ds) / (dQ/dt), dQ/dt = -2 root at cl
    dch = -(qb * ch + g) * inv_root
    if inv_zu != 0.0:
        za = (zlo - zw + zd * s) * inv_zu
        zb = (zhi - zw + zd * s) * inv_zu
        sl = min(za, zb)
        sh = max(za, zb)
        dsl = zd * inv_zu
    else:
        z = zw - zd * s
        if z < zlo or z > zhi:
            return False, 0.0, 0.0, 0.0, 0.0
        sl = -math.inf
        sh = math.inf
        dsl = 0.0
    if cl >= sl:
        lo, dlo = cl, dcl
    else:
        lo, dlo = sl, dsl
    if ch <= sh:
        hi, dhi = ch, dch
    else:
        hi, dhi = sh, dsl
    if hi < lo:
        return False, 0.0, 0.0, 0.0, 0.0
    return True, lo, hi, dlo, dhi


@njit(cache=True, error_model="numpy")
def endpoint_interval(  # type: ignore[no-untyped-def]
    qa, qb, qc, qd, qe, qf, zw, zu, zd, zlo, zhi
):
    """Swept interval from the two end poses when the extremes lie there (module doc).

    Same coefficients as ``kernels.swept_interval``; needs ``qa > 0``. Returns
    ``(ok, tmin, tmax)``; ``ok`` False: use the general path.
    """
    inv_qa = 1.0 / qa
    inv_zu = 1.0 / zu if abs(zu) > _TINY else 0.0
    ok0, lo0, hi0, dlo0, dhi0 = _static(0.0, qa, inv_qa, qb, qc, qd, qe, qf, zw, inv_zu, zd,
                                        zlo, zhi)
    if not ok0:
        return False, 0.0, 0.0
    ok1, lo1, hi1, dlo1, dhi1 = _static(1.0, qa, inv_qa, qb, qc, qd, qe, qf, zw, inv_zu, zd,
                                        zlo, zhi)
    if not ok1:
        return False, 0.0, 0.0
    # lo convex: min at 0 if it does not fall there, at 1 if it does not rise there
    if dlo0 >= 0.0:
        tmin = lo0
    elif dlo1 <= 0.0:
        tmin = lo1
    else:
        return False, 0.0, 0.0
    # hi concave: max at 0 if it does not rise there, at 1 if it does not fall there
    if dhi0 <= 0.0:
        tmax = hi0
    elif dhi1 >= 0.0:
        tmax = hi1
    else:
        return False, 0.0, 0.0
    return True, tmin, tmax


@njit(cache=True, inline="always", error_model="numpy")
def _roots_at(s, qa, qb, qc, qd, qe, qf, tmin, tmax):  # type: ignore[no-untyped-def]
    """Widen ``(tmin, tmax)`` by the roots of ``Q(t, s) = 0`` at a fixed ``s``
    (selects, no branches)."""
    b = qb * s + qd
    c = (qc * s + 2.0 * qe) * s + qf
    disc = b * b - qa * c
    has = disc >= 0.0
    root = math.sqrt(disc if has else 0.0)
    q = -(b + root) if b >= 0.0 else -(b - root)
    zero = q == 0.0
    r1 = q / qa
    r2 = c / q
    lo = 0.0 if zero else min(r1, r2)
    hi = 0.0 if zero else max(r1, r2)
    return (min(tmin, lo) if has else tmin), (max(tmax, hi) if has else tmax)


@njit(cache=True, inline="always", error_model="numpy")
def _normal_sel(qa, qb, qc, qd, qe, qf, zw, zd, zlo, zhi, alpha):  # type: ignore[no-untyped-def]
    """``normal_interval`` with selects instead of branches (vectorises in a row)."""
    # the slab zlo <= zw - zd s <= zhi as an s range within [0, 1]
    moving = abs(zd) > _TINY
    sa = (zw - zhi) / zd
    sb = (zw - zlo) / zd
    inside = (zlo <= zw) & (zw <= zhi)
    s0 = max(0.0, min(sa, sb)) if moving else 0.0
    s1 = min(1.0, max(sa, sb)) if moving else (1.0 if inside else -1.0)
    empty = s1 < s0
    tmin, tmax = _roots_at(s0, qa, qb, qc, qd, qe, qf, math.inf, -math.inf)
    tmin, tmax = _roots_at(s1, qa, qb, qc, qd, qe, qf, tmin, tmax)
    # the tangency line qb t + qc s + qe = 0 on the conic: multiplied by qc,
    # A t^2 + 2 B t + C = 0. No move across the axis (qc ~ 0): Q is linear in s, the
    # extremes lie on the lines. A = 0 for a sphere or cylinder moved along the ray
    # (within the plane normal to the axis): the section is a strip along the move,
    # its extremes on the lines too. A nearly 0 otherwise: round-off, general path.
    a = qa * qc - qb * qb
    b = qd * qc - qb * qe
    c = qf * qc - qe * qe
    flat = qc <= _TINY
    strip = (a == 0.0) & (alpha >= 0.0)
    near = abs(a) <= 1e-9 * qa * qc
    ok = ((alpha >= 0.0) & (abs(qb) <= _TINY)) if flat else (strip | (not near))
    tangent = (not flat) & (not near)
    disc = b * b - a * c
    has = tangent & (disc >= 0.0)
    root = math.sqrt(disc if has else 0.0)
    q = -(b + root) if b >= 0.0 else -(b - root)
    ok = ok & (not (has & (q == 0.0)))
    t1 = q / a
    t2 = c / q
    s1_ = -(qb * t1 + qe) / qc
    s2_ = -(qb * t2 + qe) / qc
    in1 = has & (s0 <= s1_) & (s1_ <= s1)
    in2 = has & (s0 <= s2_) & (s2_ <= s1)
    tmin = min(tmin, t1) if in1 else tmin
    tmax = max(tmax, t1) if in1 else tmax
    tmin = min(tmin, t2) if in2 else tmin
    tmax = max(tmax, t2) if in2 else tmax
    return (ok | empty), (math.inf if empty else tmin), (-math.inf if empty else tmax)


@njit(cache=True, error_model="numpy")
def normal_interval(  # type: ignore[no-untyped-def]
    qa, qb, qc, qd, qe, qf, zw, zd, zlo, zhi, alpha
):
    """Swept interval of a ray normal to the tool axis (``zu = 0``, module doc).

    Same coefficients as ``kernels.swept_interval`` (``qa = 1`` here); ``alpha`` is the
    primitive's quadratic term. Returns ``(ok, tmin, tmax)`` (``tmin > tmax``: the ray
    misses); ``ok`` False for a cone whose section degenerates, or a nearly degenerate
    section (use the general path).
    """
    return _normal_sel(qa, qb, qc, qd, qe, qf, zw, zd, zlo, zhi, alpha)


@njit(cache=True, inline="always", error_model="numpy")
def _row_ray_terms(  # type: ignore[no-untyped-def]
    w1, w0, w2, ag0, ag1, ag2, dg0, dg1, dg2, zu, zd, alpha, beta, gamma,
):
    """The height ``zw`` and the ray's terms ``qd, qe, qf`` of Q(t, s) for one ray of a
    row (``w = origin - tip``; its component along the row varies, ``w1``)."""
    zw = ag0 * w0 + ag1 * w1 + ag2 * w2
    wu = w2 - zw * zu
    wd = w0 * dg0 + w1 * dg1 + w2 * dg2 - zw * zd
    ww = w0 * w0 + w1 * w1 + w2 * w2 - zw * zw
    qd = wu + alpha * zw * zu + 0.5 * beta * zu
    qe = -wd - alpha * zw * zd - 0.5 * beta * zd
    qf = ww + alpha * zw * zw + beta * zw + gamma
    return zw, qd, qe, qf


@njit(cache=True, error_model="numpy")
def normal_row(  # type: ignore[no-untyped-def]
    out_a, out_b, out_ok, rays, n, cj0, step, h, w0, tip1, w2, ag0, ag1, ag2, dg0, dg1, dg2,
    zu, zd, alpha, beta, gamma, qa, qb, qc, zlo, zhi,
):
    """``normal_interval`` for the rays ``rays[:n]`` of one grid row, arguments as
    ``endpoint_row``; branch-free so that the loop vectorises."""
    for q in range(n):
        zw, qd, qe, qf = _row_ray_terms(cj0 + rays[q] * step * h - tip1, w0, w2, ag0, ag1,
                                        ag2, dg0, dg1, dg2, zu, zd, alpha, beta, gamma)
        ok, ta, tb = _normal_sel(qa, qb, qc, qd, qe, qf, zw, zd, zlo, zhi, alpha)
        out_a[q] = ta
        out_b[q] = tb
        out_ok[q] = ok


@njit(cache=True, inline="always", error_model="numpy")
def _static_sel(s, qa, inv_qa, qb, qc, qd, qe, qf, zw, inv_zu, zd, zlo, zhi):  # type: ignore[no-untyped-def]
    """``_static`` for ``inv_zu != 0`` written with selects instead of branches (the
    same operations, so the same numbers), for a loop that vectorises."""
    b = qb * s + qd
    c = (qc * s + 2.0 * qe) * s + qf
    disc = b * b - qa * c
    ok = disc > 0.0
    root = math.sqrt(disc if ok else 1.0)
    q = -(b + root) if b >= 0.0 else -(b - root)
    r1 = q * inv_qa
    r2 = c / q
    cl = min(r1, r2)
    ch = max(r1, r2)
    g = qc * s + qe
    inv_root = 1.0 / root
    dcl = (qb * cl + g) * inv_root
    dch = -(qb * ch + g) * inv_root
    za = (zlo - zw + zd * s) * inv_zu
    zb = (zhi - zw + zd * s) * inv_zu
    sl = min(za, zb)
    sh = max(za, zb)
    dsl = zd * inv_zu
    lo = cl if cl >= sl else sl
    dlo = dcl if cl >= sl else dsl
    hi = ch if ch <= sh else sh
    dhi = dch if ch <= sh else dsl
    return ok & (hi >= lo), lo, hi, dlo, dhi


@njit(cache=True, error_model="numpy")
def endpoint_row(  # type: ignore[no-untyped-def]
    out_a, out_b, out_ok, rays, n, cj0, step, h, w0, tip1, w2, ag0, ag1, ag2, dg0, dg1, dg2,
    zu, zd, alpha, beta, gamma, qa, qb, qc, zlo, zhi,
):
    """``endpoint_interval`` for the rays ``rays[:n]`` of one grid row (only those the
    sweep's material test passed); branch-free so that the loop vectorises. Needs
    ``|zu| > 1e-14`` and ``qa > 0``.

    Parameters
    ----------
    out_a, out_b : (>= n,) float64
        Interval ends along the rays (grid frame, mm): ray ``rays[q]``'s at ``q``.
    out_ok : (>= n,) bool
        False where the general path is needed (the values there are meaningless).
    rays, n : (>= n,) int64, int
        The rays' positions ``m`` in the row.
    cj0, step, h : float, int, float
        Ray ``m`` lies at ``cj0 + m step h`` along the row, mm.
    w0, tip1, w2 : float
        Ray offset from the tip across the rows (``w0``), the tip's coordinate along
        the row, and the ray origin's offset along the rays (``-tip``), mm.
    ag0, ag1, ag2, dg0, dg1, dg2 : float
        Tool axis (unit) and tip displacement (mm) in the grid frame.
    zu, zd, alpha, beta, gamma, qa, qb, qc, zlo, zhi : float
        Per-move and per-primitive terms as in ``kernels.swept_interval``.
    """
    inv_qa = 1.0 / qa
    inv_zu = 1.0 / zu
    for q in range(n):
        zw, qd, qe, qf = _row_ray_terms(cj0 + rays[q] * step * h - tip1, w0, w2, ag0, ag1,
                                        ag2, dg0, dg1, dg2, zu, zd, alpha, beta, gamma)
        ok0, lo0, hi0, dlo0, dhi0 = _static_sel(0.0, qa, inv_qa, qb, qc, qd, qe, qf, zw,
                                                inv_zu, zd, zlo, zhi)
        ok1, lo1, hi1, dlo1, dhi1 = _static_sel(1.0, qa, inv_qa, qb, qc, qd, qe, qf, zw,
                                                inv_zu, zd, zlo, zhi)
        out_a[q] = lo0 if dlo0 >= 0.0 else lo1
        out_b[q] = hi0 if dhi0 <= 0.0 else hi1
        out_ok[q] = (ok0 & ok1 & ((dlo0 >= 0.0) | (dlo1 <= 0.0))
                     & ((dhi0 <= 0.0) | (dhi1 >= 0.0)))


@njit(cache=True, inline="always", error_model="numpy")
def stadium_row(x, p0x, p0y, p1x, p1y, rho):  # type: ignore[no-untyped-def]
    """Span ``(ylo, yhi)`` of the line ``X = x`` within ``rho`` of the segment p0-p1
    (2-D); ``ylo > yhi`` when it misses. The stadium is convex, so the span is the
    hull of its spans in the two end discs and in the band along the segment."""
    ylo = math.inf
    yhi = -math.inf
    for px, py in ((p0x, p0y), (p1x, p1y)):
        dx = x - px
        h2 = rho * rho - dx * dx
        if h2 >= 0.0:
            hw = math.sqrt(h2)
            ylo = min(ylo, py - hw)
            yhi = max(yhi, py + hw)
    vx = p1x - p0x
    vy = p1y - p0y
    ll = math.sqrt(vx * vx + vy * vy)
    if ll > _TINY:
        nx = vx / ll
        ny = vy / ll
        dx = x - p0x
        # along the segment: 0 <= dx nx + (y - p0y) ny <= ll
        if abs(ny) > _TINY:
            ya = p0y - dx * nx / ny
            yb = p0y + (ll - dx * nx) / ny
            a_lo, a_hi = min(ya, yb), max(ya, yb)
        elif 0.0 <= dx * nx <= ll:
            a_lo, a_hi = -math.inf, math.inf
        else:
            return ylo, yhi
        # across: |dx ny - (y - p0y) nx| <= rho
        if abs(nx) > _TINY:
            yc = p0y + (dx * ny - rho) / nx
            yd = p0y + (dx * ny + rho) / nx
            c_lo, c_hi = min(yc, yd), max(yc, yd)
        elif abs(dx * ny) <= rho:
            c_lo, c_hi = -math.inf, math.inf
        else:
            return ylo, yhi
        b_lo = max(a_lo, c_lo)
        b_hi = min(a_hi, c_hi)
        if b_lo <= b_hi:
            ylo = min(ylo, b_lo)
            yhi = max(yhi, b_hi)
    return ylo, yhi
