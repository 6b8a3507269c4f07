"""Fillet (pencil) finishing: passes along each blade-to-hub fillet with a small ball.

The fillet of radius r_f is the envelope of a ball of radius r_f whose centre c
rolls along the spine (``geometry.fillet.rolling_ball``); in the plane of the two
contact normals its section is the arc of centre c from the blade contact P_b
(angle 0) to the hub contact P_h (angle Theta). A ball-end mill of radius
``r <= r_f`` touches that arc at ``c + r_f e(theta)`` when its centre is at

    q(theta) = c + (r_f - r) e(theta),   e(theta) = cos(theta) e1 + sin(theta) e2,

``e1 = -n_b`` (towards the blade contact), ``e2`` the unit part of ``-n_h`` normal
to e1. The fillet is a canal surface, so the ball of radius r centred at q lies
inside the rolling ball of radius r_f centred at c (``|q - c| + r = r_f``), which
touches but never enters the part: the pass cannot gouge. With ``r = r_f`` (the
paper's case) q = c: one pass on the spine traces the fillet exactly.

Stepping across the fillet: two balls on the circle of radius ``rho = r_f - r``
at angles ``2a`` apart leave a cusp ``h(a) = r_f - rho cos(a) - sqrt(r^2 - rho^2
sin^2(a))`` below the arc; the step is the largest ``2a`` with ``h <= scallop``
(bisection), the passes equal fractions of the local Theta.

The main finishing ball (radius R > r_f) touches blade and hub beyond the fillet,
``(R - r_f) tan(Theta / 2)`` from its contacts; between them it leaves a thin
strip on blade and hub. The pencil therefore goes on beyond the arc along the blade
(``X(p, v_b - dv) + r n``, exact on the blade side) and along the hub (the hub
foot of ``P_h + t T_h``, exact on the hub), up to that distance plus one flat
stepover, at the flat scallop stepover.

Each pass runs from the leading-edge tip to the trailing-edge tip round the fillet
of one passage wall: the wall's side plus the half of each edge's fillet pieces on
its side (``geometry.outline.blade_loop``: round caps in thirds, cut edges corner,
face, corner), so that the two walls of a blade (in two neighbouring passages)
cover its whole fillet loop between them. Only passage 0 is computed here; the
others are rotations (``paths.rotate_path``).

Each such pass is cut in three (``PARTS``): round the leading edge, along the side,
round the trailing edge, overlapping by ``PART_OVERLAP`` points. Round an edge the
blade normal, and with it the axis leaned away from the blade, turns by about 90 deg
within a few millimetres, against the sense in which it turns along the side: on
nine_blade's cut trailing edge the suction side's C ran down to -210.5 deg along the
side and back up to -176.5 deg round the corner, and A dipped by 2 deg there. In one
path the reversal removal had to bend the axis by up to 36 deg (A fell back to the
monotone fit over the whole pass), which put the cutter into the blade; the passes
were then shortened and left the fillet round that edge unfinished (up to 2.2 mm).
Each part is its own path, without reverse movements on its own.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from cam.finishing.options import scallop_stepover
from cam.finishing.paths import CutterPath, Wall, passage_walls, subset_path
from geometry.fillet import rolling_ball
from geometry.outline import OutlineSegment, blade_loop
from geometry.revolved import RevolvedSurface
from geometry.surfaces import BladeSurface, ImpellerSurfaces
from impeller_cam.errors import InputError

__all__ = ["PARTS", "FilletSection", "arc_step", "fillet_passes", "fillet_section", "pass_parts",
           "wall_interval"]

Array = NDArray[np.float64]
#: Coarse samples per outline segment (resampled to the point spacing afterwards).
_COARSE = 40
#: Finite-difference step of the segment parameter and span parameter.
_FD = 1e-6
#: The parts of each pass: round the leading edge, along the side, round the trailing
#: edge (module docstring).
PARTS = ("le", "side", "te")
#: Points each part of a pass shares with the next one.
PART_OVERLAP = 2
#: Bisection steps of the angular step.
_STEP_BISECTIONS = 60
#: Ball/fillet radius difference below which the paper's single spine pass is used, mm.
_SAME_RADIUS = 1e-6
#: Initial lean of the tool axis from the blade's ruling away from the blade face at
#: the contact (about the feed direction), deg: round the edges the face turns with
#: the pass, and an axis along the side's ruling turned about C (the junction's
#: initial posture) put the flutes into the edge face (nine_blade's cut trailing edge).
LEAN_DEG = 5.0


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def arc_step(fillet_radius: float, radius: float, scallop: float) -> float:
    """Largest angular step between pencil passes on the fillet arc, rad.

    Parameters
    ----------
    fillet_radius : float
        Fillet radius r_f, mm.
    radius : float
        Ball radius r <= r_f, mm.
    scallop : float
        Allowed cusp height, mm.

    Returns
    -------
    float
        ``2 a`` with ``h(a) = scallop`` (module docstring), at most pi; pi when even
        that leaves less than ``scallop`` (``r`` close to ``r_f``).
    """
    rho = fillet_radius - radius

    def cusp(a: float) -> float:
        return fillet_radius - rho * math.cos(a) - math.sqrt(
            max(radius * radius - (rho * math.sin(a)) ** 2, 0.0))

    hi = min(0.5 * math.pi, math.asin(min(radius / rho, 1.0)) if rho > 0 else 0.5 * math.pi)
    if cusp(hi) <= scallop:
        return 2.0 * hi
    lo = 0.0
    for _ in range(_STEP_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cusp(mid) <= scallop else (lo, mid)
    return 2.0 * lo


def wall_interval(side: int, count: int) -> tuple[float, float]:
    """Loop parameters ``(start, end)`` of a wall's pass, leading- to trailing-edge tip.

    ``blade_loop`` gives ``[pressure, TE x3, suction (reversed), LE x3]``; loop
    parameter ``L`` in ``[k, k + 1]`` is segment k at ``p = L - k``. The edge tips
    are the middles of the middle pieces. Pressure runs forward through 0 (start
    negative: taken modulo the loop length), suction backwards.
    """
    if count != 8:
        raise ValueError(f"expected an outline loop of 8 segments, got {count}")
    return (-1.5, 2.5) if side > 0 else (6.5, 2.5)


class FilletSection:
    """The rolling-ball fillet sections of one wall at loop parameters ``L``, ``(n,)``.

    Attributes
    ----------
    loop_parameter : (n,) float64
    segment : (n,) int
        Index of the outline segment of each section.
    p, v : (n,) float64
        Segment parameter and span parameter of the blade contact.
    u : (n,) float64
        Blade parameter u (the wall's own).
    centre, blade_contact, hub_contact : (n, 3) float64
        Spine point c and the two contacts, mm.
    e1, e2 : (n, 3) float64
        Unit vectors of the section plane (module docstring).
    theta : (n,) float64
        Arc angle Theta from blade to hub contact, rad.
    blade_normal, hub_normal : (n, 3) float64
        Outward unit normals at the contacts.
    ruling : (n, 3) float64
        Unit direction up the blade side (v decreasing) at the blade contact.
    """

    def __init__(self, loop: list[OutlineSegment], hub: RevolvedSurface, blade: BladeSurface,
                 fillet_radius: float, loop_parameter: Array) -> None:
        count = len(loop)
        lp = np.mod(np.asarray(loop_parameter, dtype=np.float64), count)
        segment = np.minimum(np.floor(lp).astype(np.intp), count - 1)
        p = np.clip(lp - segment, 0.0, 1.0)
        n = len(lp)
        self.loop_parameter = np.asarray(loop_parameter, dtype=np.float64)
        self.segment, self.p = segment, p
        self.v, self.u, self.theta = np.zeros(n), np.zeros(n), np.zeros(n)
        vectors = {k: np.zeros((n, 3)) for k in ("centre", "blade_contact", "hub_contact",
                                                  "blade_normal", "hub_normal", "ruling")}
        depth = 2.0 * fillet_radius + float(np.max(blade.thickness(np.linspace(0, 1, 11)))) + 1.0
        for k in np.unique(segment):
            rows = np.flatnonzero(segment == k)
            seg = loop[int(k)]
            u = seg.u_of(p[rows])
            length = np.linalg.norm(blade.camber(u, 1.0) - blade.camber(u, 0.0), axis=-1)
            track = rolling_ball(seg, hub, fillet_radius, p[rows], 1.0 + depth / length)
            self.v[rows], self.u[rows] = track.v, u
            vectors["centre"][rows] = track.centre
            vectors["blade_contact"][rows] = track.blade_contact
            vectors["hub_contact"][rows] = track.hub_contact
            vectors["blade_normal"][rows] = track.blade_normal
            vectors["hub_normal"][rows] = track.hub_normal
            up = seg.point(p[rows], track.v - _FD) - seg.point(p[rows], track.v + _FD)
            vectors["ruling"][rows] = up / (2.0 * _FD)
        self.centre = vectors["centre"]
        self.blade_contact = vectors["blade_contact"]
        self.hub_contact = vectors["hub_contact"]
        self.blade_normal = vectors["blade_normal"]
        self.hub_normal = vectors["hub_normal"]
        self.v_speed = np.linalg.norm(vectors["ruling"], axis=1)
        self.ruling = _unit(vectors["ruling"])
        self.e1 = -self.blade_normal
        cos = np.clip(np.einsum("ij,ij->i", self.e1, -self.hub_normal), -1.0, 1.0)
        self.e2 = _unit(-self.hub_normal - cos[:, None] * self.e1)
        self.theta = np.arccos(cos)


def fillet_section(surfaces: ImpellerSurfaces, wall: Wall, loop_parameter: Array
                   ) -> FilletSection:
    """``FilletSection`` of ``wall``'s blade at ``loop_parameter`` (spec's edges and r_f)."""
    spec = surfaces.spec
    loop = blade_loop(wall.blade, spec.leading_edge, spec.trailing_edge)
    return FilletSection(loop, surfaces.hub, wall.blade, spec.fillet_radius, loop_parameter)


def pass_parts(section: FilletSection, side: int) -> list[tuple[str, NDArray[np.intp]]]:
    """Point indices of the parts of a wall's passes (``PARTS``), in pass order.

    The side is loop segment 0 (pressure, run forwards) or 4 (suction, run backwards);
    points before it are round the leading edge, after it round the trailing edge.
    Neighbouring parts share ``PART_OVERLAP`` points; a part with fewer than two points
    of its own is left out (its points stay in the overlap of its neighbour).
    """
    lo = 0.0 if side > 0 else 4.0
    loop = section.loop_parameter
    on_side = (loop >= lo) & (loop <= lo + 1.0)
    first, last = int(np.argmax(on_side)), len(loop) - 1 - int(np.argmax(on_side[::-1]))
    if not on_side.any():
        return [("side", np.arange(len(loop), dtype=np.intp))]
    bounds = [(0, first), (first, last + 1), (last + 1, len(loop))]
    out = []
    for name, (a, b) in zip(PARTS, bounds, strict=True):
        if b - a < 2:
            continue
        out.append((name, np.arange(max(a - PART_OVERLAP, 0), min(b + PART_OVERLAP, len(loop)),
                                    dtype=np.intp)))
    return out


def lean_away(ruling: Array, normal: Array, angle: float) -> Array:
    """Unit ``ruling`` rows turned by ``angle`` rad towards ``normal`` (its part normal
    to the ruling), ``(n, 3)``."""
    across = _unit(normal - np.einsum("ij,ij->i", normal, ruling)[:, None] * ruling)
    return _unit(math.cos(angle) * ruling + math.sin(angle) * across)


def _stations(section: FilletSection, fillet_radius: float, radius: float, main_radius: float,
              scallop: float) -> list[tuple[str, Array]]:
    """Passes across the fillet as ``(kind, value (n,))``, blade side first.

    ``kind`` ``"blade"`` / ``"hub"``: distance beyond the contact, mm; ``"arc"``:
    angle theta, rad.
    """
    flat = scallop_stepover(radius, scallop)
    reach = max(main_radius - fillet_radius, 0.0) * np.tan(0.5 * section.theta) + flat
    extension = int(math.ceil(float(reach.max()) / flat))
    fractions = [j / extension for j in range(extension, 0, -1)]
    out: list[tuple[str, Array]] = [("blade", f * reach) for f in fractions]
    if fillet_radius - radius < _SAME_RADIUS:
        out.append(("arc", 0.5 * section.theta))
    else:
        step = arc_step(fillet_radius, radius, scallop)
        intervals = max(int(math.ceil(float(section.theta.max()) / step)), 1)
        out += [("arc", section.theta * (k / intervals)) for k in range(intervals + 1)]
    out += [("hub", f * reach) for f in fractions[::-1]]
    return out


def _pass_points(surfaces: ImpellerSurfaces, wall: Wall, section: FilletSection,
                 fillet_radius: float, radius: float, kind: str, value: Array
                 ) -> tuple[Array, Array]:
    """Ball centres and contact normals of one pass at every section, ``(n, 3)`` each."""
    if kind == "arc":
        e = np.cos(value)[:, None] * section.e1 + np.sin(value)[:, None] * section.e2
        return section.centre + (fillet_radius - radius) * e, -e
    if kind == "blade":
        loop = blade_loop(wall.blade, surfaces.spec.leading_edge, surfaces.spec.trailing_edge)
        centre = np.zeros_like(section.centre)
        normal = np.zeros_like(section.centre)
        v = section.v - value / section.v_speed
        for k in np.unique(section.segment):
            rows = np.flatnonzero(section.segment == k)
            seg = loop[int(k)]
            normal[rows] = seg.normal(section.p[rows], v[rows])
            centre[rows] = seg.point(section.p[rows], v[rows]) + radius * normal[rows]
        return centre, normal
    end = section.theta
    tangent = -np.sin(end)[:, None] * section.e1 + np.cos(end)[:, None] * section.e2
    guess = section.hub_contact + value[:, None] * tangent
    hub = surfaces.hub
    s = hub.closest_s(guess[:, 2], np.hypot(guess[:, 0], guess[:, 1]))
    phi = np.arctan2(guess[:, 1], guess[:, 0])
    normal = hub.normal(s, phi)
    return hub.point(s, phi) + radius * normal, normal


def _resampled(surfaces: ImpellerSurfaces, wall: Wall, fillet_radius: float, radius: float,
               main_radius: float, scallop: float, spacing: float) -> FilletSection:
    """Sections whose every pass has consecutive centres at most ``spacing`` apart."""
    start, end = wall_interval(wall.side, 8)
    coarse = np.linspace(start, end, int(abs(end - start) * _COARSE) + 1)
    section = fillet_section(surfaces, wall, coarse)
    steps = np.zeros(len(coarse) - 1)
    for kind, value in _stations(section, fillet_radius, radius, main_radius, scallop):
        centre, _ = _pass_points(surfaces, wall, section, fillet_radius, radius, kind, value)
        steps = np.maximum(steps, np.linalg.norm(np.diff(centre, axis=0), axis=1))
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    count = max(int(math.ceil(1.01 * arc[-1] / spacing)) + 1, 4)
    return fillet_section(surfaces, wall, np.interp(np.linspace(0.0, arc[-1], count),
                                                    arc, coarse))


def fillet_passes(surfaces: ImpellerSurfaces, radius: float, main_radius: float,
                  scallop: float, spacing: float, passage: int = 0,
                  lean: float | None = None) -> list[CutterPath]:
    """Pencil passes along the fillets of passage 0's walls (operation ``"fillet"``).

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    radius : float
        Ball radius r of the fillet tool, mm (``0 < r <= r_f``).
    main_radius : float
        Ball radius R of the blade and hub finishing, mm: the passes go on beyond the
        fillet as far as that ball leaves material (module docstring).
    scallop : float
        Allowed cusp height, mm.
    spacing : float
        Largest distance between consecutive ball centres, mm.
    lean : float, optional
        Initial lean of the axis from the blade's ruling away from the blade, rad
        (default ``LEAN_DEG``; ``fillet_plan.neck_lean`` derives it from the tool's
        neck and the shank clearance).

    Returns
    -------
    list of CutterPath
        Per wall, passes from the blade side across the fillet to the hub, each
        leading- to trailing-edge tip in three parts (``pass_parts``: names end in
        ``.le``, ``.side``, ``.te``). ``normal``: the contact normal; ``away``: the
        blade's outward normal; ``reference_axis``: the blade's ruling at the contact.

    Raises
    ------
    InputError
        No fillet in the design, or a ball larger than the fillet.
    """
    fillet_radius = float(surfaces.spec.fillet_radius)
    if fillet_radius <= 0:
        raise InputError("the design has no blade-to-hub fillet to finish",
                         field="fillet_tool", value=radius,
                         accepted="a design with blade.fillet_radius_mm > 0")
    if not 0 < radius <= fillet_radius + _SAME_RADIUS:
        raise InputError(f"a ball of radius {radius:g} mm does not fit the fillet of radius "
                         f"{fillet_radius:g} mm", field="fillet_tool", value=2.0 * radius,
                         accepted=f"a ball of diameter <= {2.0 * fillet_radius:g} mm")
    out: list[CutterPath] = []
    for wall, opposite in [pair if k == 0 else pair[::-1]
                           for pair in passage_walls(surfaces) for k in (0, 1)]:
        section = _resampled(surfaces, wall, fillet_radius, radius, main_radius, scallop,
                             spacing)
        curve_u = wall.curve_u(section.u)
        tip = opposite.tip_points(curve_u)
        stations = _stations(section, fillet_radius, radius, main_radius, scallop)
        leaned = lean_away(section.ruling, section.blade_normal,
                           math.radians(LEAN_DEG) if lean is None else lean)
        parts = pass_parts(section, wall.side)
        for k, (kind, value) in enumerate(stations):
            centre, normal = _pass_points(surfaces, wall, section, fillet_radius, radius,
                                          kind, value)
            whole = CutterPath(
                name=f"p{passage}.fillet.{wall.label}.{k:02d}", operation="fillet",
                passage=passage, centre=centre, normal=normal,
                reference_axis=leaned, away=section.blade_normal,
                opposite_tip=tip, curve_u=curve_u, blade_v=section.v, wall=wall)
            out += [replace(subset_path(whole, index), name=f"{whole.name}.{part}")
                    for part, index in parts]
    return out
