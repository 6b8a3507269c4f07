"""Meridional profiles of solids of revolution: a script's own hub for an impeller spec.

A hub (or a blank) made in build123d or cadquery is a solid of revolution about the
machine's Z axis. Its section by the half-plane ``y = 0, x > 0`` is its meridional
profile, a closed polygon in ``(r, z)`` (``meridional_profile``: points sampled on
the exact section edges, so they lie on the solid's surface). Walking that polygon
counter-clockwise (material on the left), the hub's passage-side surface runs from
the outlet to the inlet; ``hub_contour`` takes that stretch between the points
closest to a reference contour's ends, and ``with_hub`` puts it into a spec
(re-checked like a spec file: camber lines on the contour, hub and shroud apart).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.BRepAlgoAPI import BRepAlgoAPI_Section
from OCP.GCPnts import GCPnts_QuasiUniformDeflection
from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
from OCP.TopAbs import TopAbs_EDGE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

from geometry.interop import occ_shape
from geometry.spec import ImpellerSpec
from impeller_cam.errors import InputError

__all__ = ["hub_contour", "meridional_profile", "with_hub"]

#: Chordal deflection of the sampled section edges, mm.
DEFLECTION = 0.002
#: Section edge ends closer than this are joined, mm.
JOIN = 1e-4


def _section_polylines(shape: Any, deflection: float) -> list[NDArray[np.float64]]:
    """The section edges of ``shape`` by the plane y = 0, each sampled ``(n, 2)`` (x, z)."""
    section = BRepAlgoAPI_Section(occ_shape(shape), gp_Pln(gp_Pnt(0, 0, 0), gp_Dir(0, 1, 0)))
    section.Build()
    if not section.IsDone():
        raise InputError("the meridional section failed", field="shape",
                         accepted="a closed solid of revolution about Z")
    lines = []
    explorer = TopExp_Explorer(section.Shape(), TopAbs_EDGE)
    while explorer.More():
        curve = BRepAdaptor_Curve(TopoDS.Edge(explorer.Current()))
        sampler = GCPnts_QuasiUniformDeflection(curve, deflection)
        if sampler.IsDone() and sampler.NbPoints() >= 2:
            pts = [sampler.Value(i + 1) for i in range(sampler.NbPoints())]
            lines.append(np.array([[p.X(), p.Z()] for p in pts]))
        explorer.Next()
    return lines


def _chain(lines: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Join polylines end to end into one closed loop ``(k, 2)`` (not repeating the start)."""
    rest = list(lines)
    loop = [rest.pop(0)]
    while rest:
        end = loop[-1][-1]
        gaps = [min(np.linalg.norm(p[0] - end), np.linalg.norm(p[-1] - end)) for p in rest]
        k = int(np.argmin(gaps))
        if gaps[k] > JOIN:
            raise InputError("the meridional section is not one closed profile", field="shape",
                             value=f"a gap of {gaps[k]:.3g} mm",
                             accepted="one solid of revolution about Z")
        nxt = rest.pop(k)
        loop.append(nxt if np.linalg.norm(nxt[0] - end) <= JOIN else nxt[::-1])
    points = np.vstack([loop[0]] + [p[1:] for p in loop[1:]])
    if np.linalg.norm(points[0] - points[-1]) > JOIN:
        raise InputError("the meridional section is not closed", field="shape",
                         accepted="a closed solid of revolution about Z")
    return points[:-1]


def meridional_profile(shape: Any, deflection: float = DEFLECTION) -> NDArray[np.float64]:
    """Meridional profile of a solid of revolution about Z, counter-clockwise.

    Parameters
    ----------
    shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane
        One solid of revolution about the Z axis, mm (with a bore or without).
    deflection : float
        Chordal deflection of the sampling of the section's edges, mm.

    Returns
    -------
    (k, 2) float64
        ``(r, z)`` points, mm, of the closed profile in the half-plane ``x > 0``,
        counter-clockwise (material on the left); the first point is not repeated.

    Raises
    ------
    InputError
        No section in ``x > 0``, or one that is not a single closed polygon.
    """
    lines = [p for p in _section_polylines(shape, deflection) if p[:, 0].mean() > 0]
    if not lines:
        raise InputError("the shape has no section in the half-plane x > 0", field="shape",
                         accepted="a solid of revolution about Z")
    points = _chain(lines)
    r, z = points[:, 0], points[:, 1]
    signed = 0.5 * float(np.sum(r * np.roll(z, -1) - np.roll(r, -1) * z))
    return points if signed > 0 else points[::-1].copy()


def hub_contour(shape: Any, reference: NDArray[np.float64], samples: int | None = None,
                deflection: float = DEFLECTION) -> NDArray[np.float64]:
    """The passage-side contour of a hub solid, ``(z, r)`` from inlet to outlet.

    Parameters
    ----------
    shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane
        The hub: a solid of revolution about Z, mm, its flow passage side facing +z
        and +r (as an impeller spec's hub contour).
    reference : (m, 2) float64
        A meridional contour ``(z, r)``, mm, inlet to outlet (the spec's): the
        contour returned runs between the profile's points closest to its ends.
    samples : int, optional
        Points of the result, equally spaced along it (default: the profile's own
        points, at ``deflection``).
    deflection : float
        Chordal deflection of the profile's sampling, mm.

    Returns
    -------
    (n, 2) float64
        ``(z, r)`` points, mm, inlet to outlet.

    Raises
    ------
    InputError
        ``shape`` is not one solid of revolution, or fewer than 2 samples are asked.
    """
    profile = meridional_profile(shape, deflection)  # (r, z), counter-clockwise
    ends = np.asarray(reference, dtype=np.float64)[[0, -1]][:, ::-1]  # (r, z)
    inlet = int(np.argmin(np.linalg.norm(profile - ends[0], axis=1)))
    outlet = int(np.argmin(np.linalg.norm(profile - ends[1], axis=1)))
    # counter-clockwise with the material on the left, the hub surface runs outlet -> inlet
    count = (inlet - outlet) % len(profile) + 1
    stretch = np.take(profile, outlet + np.arange(count), axis=0, mode="wrap")[::-1]
    contour = stretch[:, ::-1]
    if samples is not None:
        if samples < 2:
            raise InputError("too few contour samples", field="samples", value=samples,
                             accepted="an integer >= 2")
        length = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(contour, axis=0), axis=1))]
        at = np.linspace(0.0, length[-1], samples)
        contour = np.column_stack([np.interp(at, length, contour[:, 0]),
                                   np.interp(at, length, contour[:, 1])])
    keep = np.r_[True, np.linalg.norm(np.diff(contour, axis=0), axis=1) > 1e-9]
    return np.asarray(contour[keep])


def with_hub(spec: ImpellerSpec, hub: Any, samples: int | None = None) -> ImpellerSpec:
    """``spec`` with the hub contour of a hub solid made in a script.

    Parameters
    ----------
    spec : ImpellerSpec
        The impeller (camber lines, shroud, blades...).
    hub : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane
        The hub solid (see ``hub_contour``); its bore is the spec's unless the
        profile's smallest radius is larger (a hub without bore keeps the spec's).
    samples : int, optional
        Points of the new contour (default: as sampled, see ``hub_contour``).

    Returns
    -------
    ImpellerSpec
        A new spec; the camber lines must lie on the new contour (0.05 mm).

    Raises
    ------
    InputError
        The hub is not a solid of revolution, or the spec's camber lines do not lie on
        its contour, or hub and shroud cross (``geometry.validate``).
    """
    from geometry.validate import check_spec_geometry

    contour = hub_contour(hub, spec.hub_contour, samples)
    profile = meridional_profile(hub)
    bore = float(profile[:, 0].min())
    new = dataclasses.replace(
        spec, hub_contour=contour,
        bore_radius=bore if bore > 1e-6 else spec.bore_radius)
    if new.bore_radius >= float(contour[:, 1].min()):
        raise InputError("bore is not inside the hub", field="hub", value=new.bore_radius,
                         accepted=f"a bore below the hub contour's smallest radius "
                                  f"{contour[:, 1].min():g} mm")
    check_spec_geometry(new)
    return new
