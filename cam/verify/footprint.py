"""The footprint of a swept primitive: which dexel rays one move can reach.

Bounds used by the sweep (``cam.verify.sweep``) to visit only rays that can meet a
swept primitive and still hold material there:

* ``capsule``: every swept primitive lies in a capsule (points within ``rho`` of a
  segment); a full sphere's sweep *is* that capsule, any other primitive lies within
  ``rmax`` of the parallelogram its axis sweeps (module doc of ``sweep``);
* ``box_side``: the swept primitive's bounding box along one grid coordinate (the
  primitive lies in the cylinder of radius ``rmax`` between its slab's heights);
* ``grid_rows``: the grid rows within ``rho`` of the capsule's span across them;
* ``capsule_range``: the capsule's range along the rays over a rectangle of the grid
  plane; ``tile_columns`` (the tiles of one tile row) and ``piece_misses`` (a run of
  rays of one row) compare it with the tiles' and the rays' material ranges.
"""

from __future__ import annotations

import math

from numba import njit

_GUARD = 1e-9  # mm added to every bound


@njit(cache=True, inline="always")
def capsule(tx, ty, tz, dx, dy, dz, ax, ay, az,  # type: ignore[no-untyped-def]
            alpha, beta, gamma, zlo, zhi, rmax):
    """Bounding capsule of a swept primitive (module doc), as scalars: start point,
    unit direction, length, radius, and whether it is exact (a full sphere)."""
    dl = math.sqrt(dx * dx + dy * dy + dz * dz)
    if alpha == 1.0:
        zc = -0.5 * beta
        rad = math.sqrt(max(zc * zc - gamma, 0.0))
        if zlo <= zc - rad + 1e-12 and zhi >= zc + rad - 1e-12:
            inv = 1.0 / dl if dl > 0.0 else 0.0
            return (tx + zc * ax, ty + zc * ay, tz + zc * az, dx * inv, dy * inv, dz * inv,
                    dl, rad, True)
    rho_a = rmax + 0.5 * dl  # around the axis segment at the mid move
    rho_b = math.hypot(rmax, 0.5 * (zhi - zlo))  # around the move at the mid axis
    if rho_a <= rho_b:
        return (tx + zlo * ax + 0.5 * dx, ty + zlo * ay + 0.5 * dy, tz + zlo * az + 0.5 * dz,
                ax, ay, az, zhi - zlo, rho_a + _GUARD, False)
    zm = 0.5 * (zlo + zhi)
    return (tx + zm * ax, ty + zm * ay, tz + zm * az, dx / dl, dy / dl, dz / dl, dl,
            rho_b + _GUARD, False)


@njit(cache=True, inline="always")
def box_side(t, d, a, zlo, zhi, rmax):  # type: ignore[no-untyped-def]
    """Extent ``(lo, hi)`` along one grid coordinate of a primitive swept along a move:
    the primitive lies in the cylinder of radius ``rmax`` around its axis between the
    heights ``zlo`` and ``zhi`` (the hull of two discs), whose extent along a unit
    coordinate with axis component ``a`` is the discs' centres +- ``rmax sqrt(1 -
    a^2)``; the move adds its displacement ``d``. ``t``: the tip's coordinate."""
    ext = rmax * math.sqrt(max(0.0, 1.0 - a * a)) + _GUARD
    c0 = t + zlo * a
    c1 = t + zhi * a
    return min(c0, c1) - ext + min(0.0, d), max(c0, c1) + ext + max(0.0, d)


@njit(cache=True, inline="always")
def _clip(s0, s1, p, u, lo, hi):  # type: ignore[no-untyped-def]
    """Parameter range ``[s0, s1]`` of ``p + s u`` clipped to ``lo <= . <= hi``."""
    if abs(u) < 1e-300:
        return (s0, s1) if lo <= p <= hi else (math.inf, -math.inf)
    a = (lo - p) / u
    b = (hi - p) / u
    return max(s0, min(a, b)), min(s1, max(a, b))


@njit(cache=True, inline="always")
def capsule_range(xa, xb, ya, yb, p0x, p0y, p0z, ux, uy, uz,  # type: ignore[no-untyped-def]
                  length, rho, kmin, kmax):
    """Range ``(klo, khi)`` along the rays of the capsule's points over the rectangle
    ``xa <= x <= xb``, ``ya <= y <= yb`` of the grid plane (``klo > khi``: none).

    Such points lie within ``rho`` of the part of the capsule's segment whose
    projection is within ``rho`` of the rectangle (a clipped parameter range), so
    their range is that part's range +- ``rho``, within ``kmin..kmax``."""
    s0, s1 = _clip(0.0, length, p0x, ux, xa - rho, xb + rho)
    s0, s1 = _clip(s0, s1, p0y, uy, ya - rho, yb + rho)
    if s1 < s0:
        return math.inf, -math.inf
    za = p0z + s0 * uz
    zb = p0z + s1 * uz
    return max(kmin, min(za, zb) - rho), min(kmax, max(za, zb) + rho)


@njit(cache=True, inline="always")
def piece_misses(ci, ja, jb, row0, t_lo, t_hi, mat_lo, mat_hi,  # type: ignore[no-untyped-def]
                 origin1, h, p0x, p0y, p0z, ux, uy, uz, length, rho, kmin, kmax):
    """True when the capsule cannot meet the material of rays ``ja..jb`` of the row at
    ``ci``: its range along those rays (``capsule_range``) against the tile's
    material range ``t_lo..t_hi``, then against the rays' own."""
    klo, khi = capsule_range(ci, ci, origin1 + (ja + 0.5) * h, origin1 + (jb + 0.5) * h,
                             p0x, p0y, p0z, ux, uy, uz, length, rho, kmin, kmax)
    if t_lo >= khi or t_hi <= klo:
        return True
    m_lo = math.inf
    m_hi = -math.inf
    for r in range(row0 + ja, row0 + jb + 1):
        m_lo = min(m_lo, mat_lo[r])
        m_hi = max(m_hi, mat_hi[r])
    return m_lo >= khi or m_hi <= klo


@njit(cache=True, inline="always")
def tile_columns(ti, i0, i1, jb0, jb1, tile, t_lo, t_hi,  # type: ignore[no-untyped-def]
                 origin0, origin1, h, p0x, p0y, p0z, ux, uy, uz, length, rho, kmin, kmax):
    """Columns ``(j0, j1)`` of the tiles of tile row ``ti`` (columns ``jb0..jb1``)
    whose material range the capsule's range over rows ``i0..i1`` of that tile row
    can meet (``j0 > j1``: none)."""
    xa = origin0 + (i0 + 0.5) * h
    xb = origin0 + (i1 + 0.5) * h
    first = -1
    last = -1
    for tj in range(jb0 // tile, jb1 // tile + 1):
        ja = max(jb0, tj * tile)
        jb = min(jb1, tj * tile + tile - 1)
        klo, khi = capsule_range(xa, xb, origin1 + (ja + 0.5) * h, origin1 + (jb + 0.5) * h,
                                 p0x, p0y, p0z, ux, uy, uz, length, rho, kmin, kmax)
        if t_lo[ti, tj] < khi and t_hi[ti, tj] > klo:
            if first < 0:
                first = tj
            last = tj
    if first < 0:
        return 1, 0
    return max(jb0, first * tile), min(jb1, last * tile + tile - 1)


@njit(cache=True, inline="always")
def grid_rows(p0x, p1x, rho, origin0, h, ni):  # type: ignore[no-untyped-def]
    """First and last grid row (``i``) within ``rho`` of the capsule's axis span."""
    xlo = min(p0x, p1x) - rho
    xhi = max(p0x, p1x) + rho
    i0 = max(0, int(math.ceil((xlo - origin0) / h - 0.5)))
    i1 = min(ni - 1, int(math.floor((xhi - origin0) / h - 0.5)))
    return i0, i1
