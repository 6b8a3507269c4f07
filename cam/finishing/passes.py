"""All finishing paths of one passage: junctions, blade-side passes, hub passes.

**Hub passes** run leading to trailing edge across the passage:
``phi = (1 - lambda) phi_a(s) + lambda phi_b(s)`` on the hub offset between the two
junction paths of the passage (M4's interpolation, used here for finishing), with
``ceil(widest passage / stepover)`` steps; the axis is the two walls' rulings, turned
to the pass's angle, interpolated with the same lambda. The passes span the union of
the two junction paths' hub-foot ranges: the two junction balls end at different
meridional positions (their centres sit R off the blade along its normal, which leans
up- or downstream with the blade angle; on the small fixture the suction-side ball
ends 2.1 mm upstream of the trailing edge on the hub, the pressure-side one 1.7 mm
beyond it), and stopping the passes at the shorter one left a strip of roughing stock
on the hub along the trailing edge. Beyond a junction path's end its ``phi`` is
extended linearly, and the junction itself goes on along the hub (``lambda`` = 0 or
1, paths ``<...>.hub.00.le`` / ``.te`` and ``.<n>.le`` / ``.te``) as far as its ball
keeps R from the wall's blade (``body_distance``): without it the strip between the
last pass and the wall kept 2.2 mm of roughing stock in the small fixture's
trailing-edge corner beside the suction side.

With a splitter, the hub passes of the inlet part (between the main blades, ahead of
the splitter) run up to the splitter junction's start and each one ends where its
cutter (ball, and the flutes along the pass's initial axis) would come closer than R
(+ ``SPLITTER_MARGIN``) to the splitter (``body_distance``, leading edge included;
the end found by bisection in the hub parameter s).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam.finishing.paths import (
    CutterPath,
    blade_passes,
    body_distance,
    hub_foot,
    junction_path,
    passage_walls,
    subset_path,
)
from cam.finishing.posture import rotate_about_z
from cam.finishing.spacing import chord_spacing
from geometry.revolved import RevolvedSurface
from geometry.surfaces import BladeSurface, ImpellerSurfaces
from impeller_cam.errors import InputError

__all__ = ["hub_passes", "passage_paths"]

Array = NDArray[np.float64]
#: Samples along the flutes for the clearance of a hub pass ahead of a splitter.
_REACH_SAMPLES = 9
#: Bisection steps of a hub pass's end in front of a splitter.
_END_STEPS = 30
#: A pass ahead of a splitter keeps the ball this much beyond R from it, mm (the
#: model of the splitter's round leading edge follows the solid to about 0.011 mm).
SPLITTER_MARGIN = 0.02
#: A junction's continuation along the hub starts this far (in s) past its end.
_S_GAP = 1e-9
#: Largest approach of a junction's continuation to its wall's blade below R, mm
#: (``body_distance`` reads the junction ball itself to 1e-14 mm).
_EDGE_TOLERANCE = 1e-6


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def hub_passes(first: CutterPath, second: CutterPath, hub: RevolvedSurface, radius: float,
               stepover: float, passage: int = 0, label: str = "",
               s_limits: tuple[float, float] | None = None,
               keep_clear: BladeSurface | None = None, reach: float = 0.0,
               extend_lead: bool = True, chordal: float | None = None) -> list[CutterPath]:
    """Hub passes between two junction paths of a passage, leading to trailing edge.

    Parameters
    ----------
    first, second : CutterPath
        Junction paths of the -theta wall (its pressure side) and the +theta wall.
    s_limits : (float, float), optional
        Restrict the hub meridional parameter range (splitter inlet region).
    keep_clear : BladeSurface, optional
        A blade ahead of the passes (the splitter): each pass ends where its cutter
        (the ball and, along the pass's initial axis, the flutes up to ``reach`` above
        the ball centre) would come closer than ``radius + SPLITTER_MARGIN`` to it.
    reach : float
        Flute length above the ball centre, mm.
    extend_lead : bool
        Start at the earlier of the two junction paths' starts (True) or at the later
        one (False: a splitter's leading edge, where the inlet passes take over). The
        passes always end at the later of the two ends.
    chordal : float, optional
        Chordal tolerance, mm: the spacing in s is lowered (for all passes) so that
        the chords of every pass stay within it (``spacing.chord_spacing`` of each
        pass, densely sampled).
    """
    sa, pa = hub_foot(hub, first.centre)
    sb, pb = hub_foot(hub, second.centre)
    for s_path, name in ((sa, first.name), (sb, second.name)):
        inside = (s_path > 0.0) & (s_path < 1.0)  # feet beyond the contour ends are clipped
        if np.any(np.diff(s_path[inside]) <= 0):
            raise InputError("the junction path does not advance along the hub contour",
                             field="meridional.hub", value=name,
                             accepted="a hub contour the blade root crosses once")
    ia = np.flatnonzero((sa > 0.0) & (sa < 1.0))
    ib = np.flatnonzero((sb > 0.0) & (sb < 1.0))
    if len(ia) < 2 or len(ib) < 2:
        return []
    first, second = subset_path(first, ia), subset_path(second, ib)
    sa, pa, sb, pb = sa[ia], pa[ia], sb[ib], pb[ib]
    pa, pb = np.unwrap(pa), np.unwrap(pb)
    lo = min(sa[0], sb[0]) if extend_lead else max(sa[0], sb[0])
    hi = max(sa[-1], sb[-1])
    if s_limits is not None:
        lo, hi = max(lo, s_limits[0]), min(hi, s_limits[1])
    if hi <= lo:
        return []
    # s spaced so that no pass steps further than the junction paths do: a pass's
    # centre velocity is affine in lambda, so the two boundaries bound its length
    fine = np.linspace(lo, hi, 8 * max(len(first), len(second)))
    speed = np.max([np.linalg.norm(np.diff(hub.offset(fine, _extend(fine, s_x, p_x), radius),
                                           axis=0), axis=1)
                    for s_x, p_x in ((sa, pa), (sb, pb))], axis=0)
    arc = np.concatenate([[0.0], np.cumsum(speed)])
    step = max(float(np.linalg.norm(np.diff(p.centre, axis=0), axis=1).max())
               for p in (first, second))
    if chordal is not None:
        # (the +theta wall lies less than a turn ahead of the -theta wall: below)
        fine_a, fine_b = _extend(fine, sa, pa), _extend(fine, sb, pb)
        fine_b -= 2.0 * math.pi * np.floor((fine_b[0] - fine_a[0]) / (2.0 * math.pi))
        step = min(step, _hub_chordal(hub, radius, stepover, fine, fine_a, fine_b, chordal))
    count = max(int(math.ceil(arc[-1] / step)) + 1, 2)
    s = np.interp(np.linspace(0.0, arc[-1], count), arc, fine)
    phi_a = _extend(s, sa, pa)
    phi_b = _extend(s, sb, pb)
    # the +theta wall lies less than a turn ahead of the -theta wall
    turns = np.floor((phi_b[0] - phi_a[0]) / (2.0 * math.pi))
    phi_b = phi_b - 2.0 * math.pi * turns
    pb = pb - 2.0 * math.pi * turns
    width = hub.meridian(s)[:, 1] * (phi_b - phi_a)
    passes = int(math.ceil(float(width.max()) / stepover))
    axis_a = _interp_rows(s, sa, rotate_about_z(first.reference_axis, -pa))
    axis_b = _interp_rows(s, sb, rotate_about_z(second.reference_axis, -pb))
    away_a = _interp_rows(s, sa, rotate_about_z(first.away, -pa))
    away_b = _interp_rows(s, sb, rotate_about_z(second.away, -pb))
    tip_a = _interp_rows(s, sa, first.opposite_tip)
    tip_b = _interp_rows(s, sb, second.opposite_tip)
    curve_u = np.interp(s, sa, first.curve_u)

    def phi_at(s_pass: Array, lam: float) -> Array:
        return np.asarray((1.0 - lam) * np.interp(s_pass, s, phi_a)
                          + lam * np.interp(s_pass, s, phi_b))

    def axis_at(s_pass: Array, lam: float, phi: Array) -> Array:
        """Reference axis of the pass at ``lam``, blended and turned to ``phi``."""
        return _unit(rotate_about_z((1.0 - lam) * _interp_rows(s_pass, s, axis_a)
                                    + lam * _interp_rows(s_pass, s, axis_b), phi))

    def make(name: str, s_pass: Array, lam: float) -> CutterPath:
        phi = phi_at(s_pass, lam)
        axis = axis_at(s_pass, lam, phi)
        near_first = lam < 0.5
        away_rows = _interp_rows(s_pass, s, away_a if near_first else away_b)
        return CutterPath(
            name=name, operation="hub", passage=passage,
            centre=hub.offset(s_pass, phi, radius), normal=hub.normal(s_pass, phi),
            reference_axis=axis, away=_unit(rotate_about_z(away_rows, phi)),
            opposite_tip=_interp_rows(s_pass, s, tip_a if near_first else tip_b),
            curve_u=np.interp(s_pass, s, curve_u), hub_contact=hub.point(s_pass, phi),
            open_end=keep_clear is not None,
        )

    out = []
    for k in range(1, passes):
        lam = k / passes

        def clearance(s_at: Array, lam: float = lam) -> Array:
            """Distance of the cutter's axis segment from ``keep_clear`` minus R, mm."""
            assert keep_clear is not None
            phi = phi_at(s_at, lam)
            centre = hub.offset(s_at, phi, radius)
            up = axis_at(s_at, lam, phi)
            heights = np.linspace(0.0, reach, _REACH_SAMPLES if reach > 0 else 1)
            points = centre[:, None, :] + heights[None, :, None] * up[:, None, :]
            distance = body_distance(keep_clear, points.reshape(-1, 3))
            return np.asarray(distance.reshape(len(s_at), -1).min(axis=1) - radius)

        s_pass = s
        if keep_clear is not None:
            near = np.flatnonzero(clearance(s) < SPLITTER_MARGIN)
            if near.size:
                stop = int(near[0])
                if stop == 0:
                    continue
                lo_s, hi_s = np.array([s[stop - 1]]), np.array([s[stop]])
                for _ in range(_END_STEPS):
                    mid = 0.5 * (lo_s + hi_s)
                    ok = clearance(mid) >= SPLITTER_MARGIN
                    lo_s, hi_s = np.where(ok, mid, lo_s), np.where(ok, hi_s, mid)
                s_pass = np.concatenate([s[:stop], lo_s])
                if len(s_pass) < 2:
                    continue
        out.append(make(f"p{passage}.hub{label}.{k:02d}", s_pass, lam))
    # the junction paths end at different hub positions: beyond the shorter one the
    # strip between the last hub pass and its wall is cut by the junction's
    # continuation along the hub (lambda = 0 or 1), as far as its ball keeps R from
    # the wall's blade; machined before the first and after the last pass
    for k, s_j, wall in ((0, sa, first.wall), (passes, sb, second.wall)):
        lam = k / passes
        edges: list[CutterPath] = []
        for end, s_pass in (("le", np.concatenate([s[s < s_j[0] - _S_GAP], s_j[:1]])),
                            ("te", np.concatenate([s_j[-1:], s[s > s_j[-1] + _S_GAP]]))):
            if len(s_pass) < 2 or wall is None:
                continue
            clear = body_distance(wall.blade, hub.offset(s_pass, phi_at(s_pass, lam), radius)
                                  ) - radius
            ok = clear >= -_EDGE_TOLERANCE
            # from the junction's end outwards, up to the first point too close
            run = ok[::-1] if end == "le" else ok
            keep = len(run) if run.all() else int(np.argmin(run))
            if keep < 2:
                continue
            s_pass = s_pass[len(s_pass) - keep:] if end == "le" else s_pass[:keep]
            edges.append(make(f"p{passage}.hub{label}.{k:02d}.{end}", s_pass, lam))
        out = edges + out if k == 0 else out + edges
    return out


def _hub_chordal(hub: RevolvedSurface, radius: float, stepover: float, s: Array,
                 phi_a: Array, phi_b: Array, tolerance: float) -> float:
    """Largest step along the hub passes keeping their chords within ``tolerance``.

    Every pass ``phi = (1 - lambda) phi_a + lambda phi_b`` (and the two boundaries)
    sampled at ``s`` (dense); mm.
    """
    width = hub.meridian(s)[:, 1] * (phi_b - phi_a)
    passes = max(int(math.ceil(float(width.max()) / stepover)), 1)
    return min(chord_spacing(hub.offset(s, (1.0 - lam) * phi_a + lam * phi_b, radius),
                             tolerance, math.inf)
               for lam in np.linspace(0.0, 1.0, passes + 1))


def _extend(x: Array, xp: Array, fp: Array) -> Array:
    """``np.interp`` inside ``xp``, linear continuation of the end segments outside."""
    out = np.interp(x, xp, fp)
    before, after = x < xp[0], x > xp[-1]
    out[before] = fp[0] + (x[before] - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0])
    out[after] = fp[-1] + (x[after] - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    return np.asarray(out)


def _interp_rows(x: Array, xp: Array, rows: Array) -> Array:
    return np.stack([np.interp(x, xp, rows[:, j]) for j in range(rows.shape[1])], axis=1)


def passage_paths(surfaces: ImpellerSurfaces, radius: float, spacing: float,
                  stepover: float, *, blade: bool = True, hub: bool = True,
                  reach: float = 0.0, chordal: float | None = None) -> list[CutterPath]:
    """All finishing paths of passage 0: junctions, then blade passes, then hub passes.

    ``reach`` (mm) is the flute length above the ball centre: the inlet hub passes
    ahead of a splitter keep ball and flutes clear of it (``hub_passes``).
    ``chordal`` (mm, optional): the chordal tolerance; each path's (each group of
    blade or hub passes') spacing is lowered below ``spacing`` so that its chords
    stay within it (``cam/finishing/spacing.py``).

    Raises
    ------
    InputError
        The ball is smaller than the fillet radius (it would cut into the fillet),
        or it does not fit between blade and hub.
    """
    fillet = surfaces.spec.fillet_radius
    if radius < fillet - 1e-9:
        raise InputError(
            f"the ball (radius {radius:g} mm) is smaller than the fillet radius "
            f"{fillet:g} mm: its junction path would cut into the fillet",
            field="tool", value=2.0 * radius,
            accepted=f"a ball of diameter >= {2.0 * fillet:g} mm")
    pairs = passage_walls(surfaces)
    junctions: list[tuple[CutterPath, CutterPath]] = []
    for a, b in pairs:
        junctions.append((junction_path(a, b, surfaces.hub, radius, spacing, chordal=chordal),
                          junction_path(b, a, surfaces.hub, radius, spacing, chordal=chordal)))
    out: list[CutterPath] = [p for pair in junctions for p in pair]
    if blade:
        for a, b in pairs:
            out += blade_passes(a, b, surfaces.hub, radius, stepover, spacing, chordal=chordal)
            out += blade_passes(b, a, surfaces.hub, radius, stepover, spacing, chordal=chordal)
    if hub:
        if len(junctions) == 1:
            out += hub_passes(*junctions[0], surfaces.hub, radius, stepover, chordal=chordal)
        else:
            (ja, js), (jp, jb) = junctions
            out += hub_passes(ja, js, surfaces.hub, radius, stepover, label="a",
                              extend_lead=False, chordal=chordal)
            out += hub_passes(jp, jb, surfaces.hub, radius, stepover, label="b",
                              extend_lead=False, chordal=chordal)
            # inlet region ahead of the splitter: between the main blades, each pass
            # ending where its ball would come within R of the splitter
            s_split = max(hub_foot(surfaces.hub, js.centre)[0][0],
                          hub_foot(surfaces.hub, jp.centre)[0][0])
            out += hub_passes(ja, jb, surfaces.hub, radius, stepover, label="i",
                              s_limits=(0.0, s_split), keep_clear=surfaces.splitters[0],
                              reach=reach, chordal=chordal)
    return out
