"""Imported mean lines -> the product's spec: camber lines, thickness law, splitter start.

* Hub and shroud camber lines are the first and last span's mean lines, each moved
  onto its meridional contour (keeping theta; the shift is reported). A third span
  nearest 50 % becomes the mid-span line of a non-ruled blade when it lies more
  than ``RULED_TOLERANCE`` off the ruled surface through hub and shroud.
* The thickness law: per mean-line point (BladeGen: the sections' gaps) at the
  camber parameter u of that point, or the file's own ``(u, mm)`` curves
  (CFturbo); averaged over the spans (the spec has one law; the spread is
  reported); a law constant to ``CONSTANT_TOLERANCE`` becomes ``thickness_mm``.
* A splitter is the main blade cut at u_s and turned half a pitch: u_s is the
  closest point of the main hub line to the splitter's hub leading edge.

What the aero formats do not carry (bore, fillet, allowances, machining) comes from
a manufacturing TOML: ``[hub]``, ``[blade] fillet_radius_mm``, ``[allowances]``,
``[machining]`` tables of the spec (docs/import-export.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import tomli_w
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline, PchipInterpolator
from scipy.optimize import minimize_scalar

from geometry.camber import camber_curves, chord_parameter, common_nodes, cylindrical_to_cartesian
from geometry.design import FILES
from geometry.design_files import camber_csv_text
from geometry.exchange.model import AeroBlade, AeroBlading
from geometry.figures import project_on_camber
from geometry.revolved import RevolvedSurface
from geometry.spec_schema import MIN_SPLINE_POINTS
from geometry.surfaces import BladeSurface, rotation_z
from impeller_cam.errors import InputError

__all__ = ["CONSTANT_TOLERANCE", "RULED_TOLERANCE", "ImportedSpec", "imported_spec"]

Array = NDArray[np.float64]
#: A mid-span line closer than this (mm) to the ruled surface gives a ruled blade.
RULED_TOLERANCE = 1e-3
#: A thickness law varying less than this (mm) is written as one thickness.
CONSTANT_TOLERANCE = 1e-4


@dataclass
class ImportedSpec:
    """The spec texts of an import and what was found on the way (for the report).

    Attributes
    ----------
    texts : dict of str to str
        File name -> text (``spec.toml`` and the camber CSVs).
    facts : dict
        JSON-ready findings: thickness law, spread, rule deviations, shifts, splitter.
    """

    texts: dict[str, str]
    facts: dict[str, Any] = field(default_factory=dict)


def _same_counts(blade: AeroBlade, notes: list[str]) -> list[Array]:
    """Mean lines resampled to one point count (by chord fraction) when they differ."""
    counts = {len(line) for line in blade.mean_lines}
    if len(counts) == 1:
        return blade.mean_lines
    n = max(counts)
    notes.append(f"mean lines of {sorted(counts)} points resampled to {n} by chord fraction")
    out = []
    for line in blade.mean_lines:
        t = chord_parameter(cylindrical_to_cartesian(line))
        out.append(np.asarray(CubicSpline(t, line, axis=0)(np.linspace(0.0, 1.0, n))))
    return out


def _on_contour(line: Array, contour: Array, side: int) -> tuple[Array, float]:
    """``line`` (n, 3) r, theta, z moved onto the revolved ``contour``; largest shift, mm."""
    surface = RevolvedSurface(contour, passage_side=side)
    foot = surface.meridian(surface.closest_s(line[:, 2], line[:, 0]))
    shift = float(np.max(np.hypot(foot[:, 0] - line[:, 2], foot[:, 1] - line[:, 0])))
    return np.column_stack([foot[:, 1], line[:, 1], foot[:, 0]]), shift


def _deviation(ruled: BladeSurface, line: Array, span: float) -> tuple[float, float]:
    """Largest distance (mm) of a mean line from a camber surface, and its u there."""
    points = cylindrical_to_cartesian(line)
    u0 = np.linspace(0.0, 1.0, len(points))
    dist = project_on_camber(ruled, points, u0, np.full(len(points), 1.0 - span))
    i = int(np.argmax(dist))
    return float(dist[i]), float(u0[i])


def _thickness(blade: AeroBlade, nodes: Array) -> tuple[Array, Array, float]:
    """Knots (u, mm) of the averaged law and the spread over the spans, mm."""
    if blade.thickness_at_points and all(len(law) == len(nodes) for law in blade.thickness):
        values = np.array([law[:, 1] for law in blade.thickness])
        u = nodes
    else:
        u = np.unique(np.concatenate([law[:, 0] for law in blade.thickness]))
        values = np.array([PchipInterpolator(law[:, 0], law[:, 1])(u)
                           for law in blade.thickness])
    mean = values.mean(axis=0)
    return u, mean, float(np.ptp(values, axis=0).max())


def _law_text(u: Array, mm: Array, where: str) -> tuple[str, dict[str, Any]]:
    if np.any(mm <= 0):
        i = int(np.argmin(mm))
        raise InputError(f"blade thickness {mm[i]:.4g} mm at u = {u[i]:.4f}", file=where,
                         field="thickness", accepted="a thickness > 0 everywhere (a cut edge "
                         "is a face of two corners, a rounded edge a cap around its centre)")
    if abs(u[0]) > 1e-9 or abs(u[-1] - 1.0) > 1e-9:
        raise InputError("thickness law does not span the blade", file=where,
                         field="thickness", value=[float(u[0]), float(u[-1])],
                         accepted="thickness from the leading edge (0) to the trailing edge (1)")
    if float(np.ptp(mm)) < CONSTANT_TOLERANCE:
        value = round(float(mm.mean()), 6)
        return f"thickness_mm = {value!r}", {"kind": "constant", "mm": value}
    u = np.clip(u, 0.0, 1.0)
    u[0], u[-1] = 0.0, 1.0
    us = ", ".join(repr(round(float(x), 9)) for x in u)
    ms = ", ".join(repr(round(float(x), 6)) for x in mm)
    return (f"thickness = {{ u = [{us}], mm = [{ms}] }}",
            {"kind": "pchip", "knots": len(u), "min_mm": float(mm.min()),
             "max_mm": float(mm.max())})


def _splitter(main: tuple[Any, Any, Any], blade: AeroBlade, sets: int,
              lines: list[Array]) -> tuple[float, dict[str, Any]]:
    """Splitter start u_s on the main blade and the splitter's deviation from it, mm."""
    p, q, m = main
    fits = []
    for sign in (-1.0, 1.0):  # the file's splitter may follow or precede the main blade
        turn = rotation_z(sign * math.pi / sets)
        le = cylindrical_to_cartesian(lines[0][0]) @ turn.T
        fit = minimize_scalar(lambda u, le=le: float(np.linalg.norm(q(u) - le)),
                              bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-10})
        fits.append((float(fit.fun), sign, fit))
    _, sign, fit = min(fits, key=lambda f: f[0])
    turn = rotation_z(sign * math.pi / sets)
    start = float(fit.x)
    surface = BladeSurface(p, q, lambda u: u, midspan=m)
    worst, where = 0.0, 0.0
    for line, span in zip(lines, blade.spans, strict=True):
        pts = cylindrical_to_cartesian(line) @ turn.T
        u0 = start + np.linspace(0.0, 1.0, len(pts)) * (1.0 - start)
        dist = project_on_camber(surface, pts, u0, np.full(len(pts), 1.0 - span))
        if dist.max() > worst:
            worst, where = float(dist.max()), float(span)
    return start, {"start_fraction": round(start, 9), "hub_le_gap_mm": float(fit.fun),
                   "deviation_from_main_mm": worst, "deviation_span": where}


def _contour_text(points: Array) -> str:
    return "[\n" + "".join(f"    [{a:.9f}, {b:.9f}],\n" for a, b in points) + "]"


def imported_spec(blading: AeroBlading, manufacturing: dict[str, Any]) -> ImportedSpec:
    """Spec texts of ``blading`` (see module docstring).

    Parameters
    ----------
    blading : AeroBlading
    manufacturing : dict
        The manufacturing TOML's tables (``hub``, ``blade``, ``allowances``,
        ``machining``, ``impeller``), already read.

    Raises
    ------
    InputError
        A thickness not > 0, too few mean-line points, a splitter starting outside
        the spec's range.
    """
    src = str(blading.source)
    main = blading.blades[0]
    notes = list(blading.notes)
    lines = _same_counts(main, notes)
    if len(lines[0]) < MIN_SPLINE_POINTS:
        raise InputError(f"mean lines of {len(lines[0])} points", file=src,
                         accepted=f"at least {MIN_SPLINE_POINTS} points per span")
    hub_line, hub_shift = _on_contour(lines[0], blading.hub, +1)
    shroud_line, shroud_shift = _on_contour(lines[-1], blading.shroud, -1)
    p, q, _ = camber_curves(shroud_line, hub_line)
    ruled = BladeSurface(p, q, lambda u: u)
    deviations = [dict(zip(("mm", "u"), _deviation(ruled, line, float(span)), strict=True),
                       span=float(span)) for line, span in zip(lines, main.spans, strict=True)]
    mid = None
    if len(lines) >= 3:
        k = 1 + int(np.argmin(np.abs(main.spans[1:-1] - 0.5)))
        if deviations[k]["mm"] > RULED_TOLERANCE:
            mid = lines[k]
    nodes = common_nodes([shroud_line, hub_line] + ([] if mid is None else [mid]))[0]
    u, mm, spread = _thickness(main, nodes)
    law, law_facts = _law_text(u, mm, src)
    p, q, m = camber_curves(shroud_line, hub_line, mid)
    split_start, split_facts = 0.35, dict[str, Any]()
    if len(blading.blades) > 1:
        split_lines = _same_counts(blading.blades[1], notes)
        split_start, split_facts = _splitter((p, q, m), blading.blades[1], blading.blade_sets,
                                             split_lines)
        if not 0.05 <= split_start <= 0.9:
            raise InputError(f"the splitter starts at u = {split_start:.3f} of the main blade",
                             file=src, field="splitter",
                             accepted="a splitter leading edge between u = 0.05 and 0.9")
    name = str(manufacturing.get("impeller", {}).get("name", blading.name))
    hub_table = manufacturing.get("hub", {"bore_radius_mm": round(
        0.5 * float(blading.hub[:, 1].min()), 6)})
    if "hub" not in manufacturing:
        notes.append(f"bore radius not given: {hub_table['bore_radius_mm']} mm (half the "
                     "smallest hub radius) assumed")
    fillet = float(manufacturing.get("blade", {}).get("fillet_radius_mm", 0.0))
    texts = {FILES["shroud"]: camber_csv_text(shroud_line), FILES["hub"]: camber_csv_text(hub_line)}
    if mid is not None:
        texts[FILES["midspan"]] = camber_csv_text(mid)
    tables: dict[str, Any] = {k: manufacturing[k] for k in ("allowances", "machining")
                              if k in manufacturing}
    texts["spec.toml"] = (
        f"# Imported by impeller-cam import from {blading.source.name} ({blading.format}, "
        f"{blading.unit}); see import_report.txt\n"
        f"[impeller]\nname = {tomli_w.dumps({'n': name})[4:].strip()}\n"
        f"blades = {blading.blade_sets}\n\n"
        f'[camber]\nshroud = "{FILES["shroud"]}"\nhub = "{FILES["hub"]}"\n'
        + ("" if mid is None else f'midspan = "{FILES["midspan"]}"\n')
        + f"\n[meridional]\nhub = {_contour_text(blading.hub)}\n"
        f"shroud = {_contour_text(blading.shroud)}\n\n"
        + tomli_w.dumps({"hub": hub_table}) + "\n"
        f'[blade]\n{law}\nleading_edge = "{main.leading_edge}"\n'
        f'trailing_edge = "{main.trailing_edge}"\nfillet_radius_mm = {fillet!r}\n\n'
        f"[splitters]\ncount = {len(blading.blades) - 1}\n"
        f"start_fraction = {round(split_start, 9)!r}\n\n"
        + (tomli_w.dumps(tables) if tables else "")
    )
    facts = {
        "thickness_law": law_facts, "thickness_spread_mm": spread,
        "rule_deviation": deviations, "ruled": mid is None,
        "contour_shift_mm": {"hub": hub_shift, "shroud": shroud_shift},
        "splitter": split_facts or None, "notes": notes,
    }
    return ImportedSpec(texts, facts)
