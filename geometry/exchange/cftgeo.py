"""CFturbo exchange files (``.cft-geo``, XML): meridional contours, mean lines, thickness.

As CFturbo's manual describes the format: a length unit (``LengthMm``, ``LengthM``,
``LengthIn``; ``LengthCm`` is accepted too), hub and shroud contours as arrays of
``(r, z)`` curves, and per blade (main, then splitter) the span positions (0 hub to
1 shroud), one mean line of ``(r, T, z)`` points per span (T = theta, rad) and two
thickness curves ``(x, y)`` -- hub then shroud -- with x the relative position
along the mean line and y the thickness. The element names used here are listed in
docs/import-export.md (CFturbo's own schema is not public); any other axis than Z is
refused.
"""

from __future__ import annotations

import math
import xml.sax
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from geometry.exchange.bladegen import EDGE_KEYS
from geometry.exchange.model import AeroBlade, AeroBlading, length_factor
from impeller_cam.errors import InputError

__all__ = ["CFT_UNITS", "cftgeo_text", "read_cftgeo"]

Array = NDArray[np.float64]
#: ``.cft-geo`` length units and the product's unit names.
CFT_UNITS = {"lengthm": "M", "lengthcm": "CM", "lengthmm": "MM", "lengthin": "IN"}


@dataclass
class _Node:
    tag: str
    attrs: dict[str, str]
    line: int
    text: str = ""
    children: list[_Node] = field(default_factory=list)

    def all(self, tag: str) -> list[_Node]:
        return [c for c in self.children if c.tag.lower() == tag.lower()]

    def one(self, tag: str, path: Path) -> _Node:
        found = self.all(tag)
        if not found:
            raise InputError(f"line {self.line}: <{self.tag}> has no <{tag}>", file=path,
                             field=tag, accepted=f"a <{tag}> element inside <{self.tag}>")
        return found[0]


class _Builder(xml.sax.ContentHandler):
    def __init__(self) -> None:
        super().__init__()
        self.stack: list[_Node] = []
        self.root: _Node | None = None
        self._locator: xml.sax.xmlreader.Locator | None = None

    def setDocumentLocator(self, locator: xml.sax.xmlreader.Locator) -> None:  # noqa: N802
        self._locator = locator

    def startElement(self, name: str, attrs: xml.sax.xmlreader.AttributesImpl) -> None:  # noqa: N802
        line = int(self._locator.getLineNumber() or 0) if self._locator else 0
        node = _Node(name, dict(attrs), line)
        if self.stack:
            self.stack[-1].children.append(node)
        else:
            self.root = node
        self.stack.append(node)

    def endElement(self, name: str) -> None:  # noqa: N802
        self.stack.pop()

    def characters(self, content: str) -> None:
        if self.stack:
            self.stack[-1].text += content


def _parse(path: Path) -> _Node:
    if not path.is_file():
        raise InputError("file not found", file=path, value=str(path),
                         accepted="an existing CFturbo .cft-geo file")
    builder = _Builder()
    try:
        xml.sax.parse(str(path), builder)
    except xml.sax.SAXParseException as error:
        raise InputError(f"line {error.getLineNumber()}: not well-formed XML "
                         f"({error.getMessage()})", file=path,
                         accepted="a CFturbo .cft-geo XML file") from None
    assert builder.root is not None
    return builder.root


def _number(path: Path, node: _Node, key: str) -> float:
    text = node.attrs.get(key, node.attrs.get(key.lower()))
    try:
        value = float(text) if text is not None else math.nan
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise InputError(f"line {node.line}: <{node.tag}> attribute {key} is not a number",
                         file=path, field=key, value=text, accepted="a finite number")
    return value


def _curve(path: Path, node: _Node, keys: tuple[str, ...], minimum: int) -> Array:
    points = node.all("Point")
    if len(points) < minimum:
        raise InputError(f"line {node.line}: <{node.tag}> has {len(points)} points", file=path,
                         accepted=f"at least {minimum} <Point {' '.join(keys)}> elements")
    return np.array([[_number(path, p, k) for k in keys] for p in points])


def _contour(path: Path, parent: _Node, tag: str, scale: float) -> Array:
    """Contour ``z, r`` (mm) of the ``(r, z)`` curves of ``tag``, inlet to outlet."""
    node = parent.one(tag, path)
    curves = [_curve(path, c, ("r", "z"), 2) for c in node.all("Curve")]
    if not curves:
        raise InputError(f"line {node.line}: <{tag}> has no <Curve>", file=path,
                         accepted="at least one <Curve> of (r, z) points")
    points = [curves[0]] + [c[1:] if np.allclose(c[0], prev[-1]) else c
                            for prev, c in zip(curves, curves[1:], strict=False)]
    rz = np.vstack(points) * scale
    zr = rz[:, ::-1].copy()
    return zr[::-1].copy() if zr[-1, 1] < zr[0, 1] else zr


def _edge(path: Path, node: _Node, key: str, default: str, notes: list[str]) -> str:
    value = node.attrs.get(key)
    if value is None:
        notes.append(f"<Blade> line {node.line}: no {key}, {default} assumed")
        return default
    shape = EDGE_KEYS.get(value.lower(), value.lower() if value.lower() in ("round", "cut")
                          else None)
    if shape is None:
        raise InputError(f"line {node.line}: unsupported {key}", file=path, field=key,
                         value=value, accepted="EllipseEnd, CutOffEnd, round or cut")
    return shape


def _blade(path: Path, node: _Node, scale: float, notes: list[str]) -> AeroBlade:
    span_node = node.one("SpanPositions", path)
    try:
        spans = np.array([float(x) for x in span_node.text.split()])
    except ValueError:
        spans = np.array([math.nan])
    mean = node.one("MeanLines", path)
    curves = mean.all("Curve")
    if len(curves) < 2 or len(spans) != len(curves) or not np.all(np.isfinite(spans)) \
            or np.any(np.diff(spans) <= 0):
        raise InputError(f"line {span_node.line}: {len(curves)} mean lines for span positions "
                         f"{span_node.text.strip()!r}", file=path, field="SpanPositions",
                         accepted="at least two spans, increasing from hub (0) to shroud (1), "
                         "one <Curve> of <MeanLines> per span")
    lines: list[Array] = []
    for curve in curves:
        rtz = _curve(path, curve, ("r", "T", "z"), 4)
        if len(rtz) != len(lines[0] if lines else rtz):
            raise InputError(f"line {curve.line}: mean line of {len(rtz)} points, the first "
                             f"has {len(lines[0])}", file=path, field="MeanLines",
                             accepted="the same number of points on every mean line")
        lines.append(np.column_stack([rtz[:, 0] * scale, np.unwrap(rtz[:, 1]),
                                      rtz[:, 2] * scale]))
    thick = node.one("Thickness", path)
    laws = [_curve(path, c, ("x", "y"), 2) for c in thick.all("Curve")]
    if len(laws) != 2:
        raise InputError(f"line {thick.line}: {len(laws)} thickness curves", file=path,
                         field="Thickness", accepted="two <Curve>s: hub, then shroud")
    for law, c in zip(laws, thick.all("Curve"), strict=True):
        if abs(law[0, 0]) > 1e-9 or abs(law[-1, 0] - 1) > 1e-9 or np.any(np.diff(law[:, 0]) <= 0):
            raise InputError(f"line {c.line}: thickness positions must increase from 0 to 1",
                             file=path, field="Thickness", value=law[:, 0].tolist(),
                             accepted="x from 0 (leading edge) to 1 (trailing edge)")
        law[:, 1] *= scale
    hub_law, shroud_law = laws
    per_span = [np.column_stack([hub_law[:, 0], hub_law[:, 1]]) if s < 0.5 else shroud_law
                for s in spans]
    if len(spans) > 2:  # interpolate the thickness of inner spans between hub and shroud
        x = np.unique(np.concatenate([hub_law[:, 0], shroud_law[:, 0]]))
        hub_y, shroud_y = (np.interp(x, law[:, 0], law[:, 1]) for law in laws)
        per_span = [np.column_stack([x, (1 - s) * hub_y + s * shroud_y]) for s in spans]
    return AeroBlade(spans, lines, per_span, _edge(path, node, "leadingEdge", "round", notes),
                     _edge(path, node, "trailingEdge", "cut", notes))


def read_cftgeo(path: str | Path) -> AeroBlading:
    """Read a ``.cft-geo`` file into an :class:`AeroBlading` (see module docstring).

    Raises
    ------
    InputError
        Not XML, a missing element, an unknown unit, an axis other than Z, fewer than
        two spans, mean lines of different point counts, more than a main blade and a
        splitter (each names the file and line).
    """
    path = Path(path)
    root = _parse(path)
    general = root.one("General", path)
    unit_node = general.one("LengthUnit", path)
    unit = CFT_UNITS.get(unit_node.text.strip().lower())
    if unit is None:
        raise InputError(f"line {unit_node.line}: unknown length unit", file=path,
                         field="LengthUnit", value=unit_node.text.strip(),
                         accepted="LengthMm, LengthCm, LengthM or LengthIn")
    scale = length_factor(unit, path, unit_node.line)
    for axis in general.all("AxisOfRotation"):
        if axis.text.strip().upper() != "Z":
            raise InputError(f"line {axis.line}: unsupported axis of rotation", file=path,
                             field="AxisOfRotation", value=axis.text.strip(), accepted="Z")
    count = general.one("NumberOfBlades", path)
    try:
        sets = int(count.text.strip())
    except ValueError:
        sets = 0
    if not 1 <= sets <= 64:
        raise InputError(f"line {count.line}: unsupported number of blades", file=path,
                         field="NumberOfBlades", value=count.text.strip(),
                         accepted="an integer from 1 to 64")
    names = general.all("Name")
    meridian = root.one("Meridian", path)
    hub = _contour(path, meridian, "HubContour", scale)
    shroud = _contour(path, meridian, "ShroudContour", scale)
    blades_node = root.one("Blades", path)
    nodes = blades_node.all("Blade")
    if not 1 <= len(nodes) <= 2:
        raise InputError(f"line {blades_node.line}: {len(nodes)} blades per set", file=path,
                         field="Blades", accepted="a main blade and at most one splitter")
    notes: list[str] = []
    blades = [_blade(path, n, scale, notes) for n in nodes]
    name = names[0].text.strip() if names and names[0].text.strip() else path.stem
    return AeroBlading(path, "cft-geo", unit, name, sets, hub, shroud, blades, notes)


# -- writer ----------------------------------------------------------------------------
def _points(values: Array, keys: tuple[str, ...], indent: str) -> str:
    return "".join(indent + "<Point " + " ".join(f'{k}="{v:.9f}"' for k, v in
                                                  zip(keys, row, strict=True)) + "/>\n"
                   for row in values)


def cftgeo_text(name: str, blades: int, unit: str, hub: Array, shroud: Array,
                mean: list[list[Array]], spans: Array, thickness: list[Array],
                leading_edge: str, trailing_edge: str) -> str:
    """The ``.cft-geo`` XML text.

    Parameters
    ----------
    name : str
    blades : int
        Number of main blades.
    unit : str
        ``M``, ``CM``, ``MM`` or ``IN``; all lengths given here are mm.
    hub, shroud : (k, 2) float64
        Meridional contours ``z, r``, mm.
    mean : list (per blade of the set) of list (per span, hub first) of (n, 3)
        Mean lines ``r, theta, z`` (mm, rad, mm).
    spans : (s,) float64
    thickness : list (per blade) of (m, 2) float64
        ``(x, thickness mm)``, written for hub and shroud alike.
    """
    scale = 1.0 / length_factor(unit, Path(name))
    cft_unit = {v: k for k, v in CFT_UNITS.items()}[unit.upper()]
    cft_unit = "Length" + cft_unit[len("length"):].capitalize()
    edge = {"round": "EllipseEnd", "cut": "CutOffEnd"}
    out = ['<?xml version="1.0" encoding="UTF-8"?>\n',
           "<!-- CFturbo exchange geometry written by impeller-cam export "
           "(docs/import-export.md) -->\n<CFturboGeometry>\n  <General>\n",
           f"    <Name>{name}</Name>\n    <LengthUnit>{cft_unit}</LengthUnit>\n",
           "    <AxisOfRotation>Z</AxisOfRotation>\n    <Unshrouded>1</Unshrouded>\n",
           f"    <NumberOfBlades>{blades}</NumberOfBlades>\n  </General>\n  <Meridian>\n"]
    for tag, contour in (("HubContour", hub), ("ShroudContour", shroud)):
        rz = contour[:, ::-1] * scale
        out.append(f"    <{tag}>\n      <Curve>\n{_points(rz, ('r', 'z'), ' ' * 8)}"
                   f"      </Curve>\n    </{tag}>\n")
    out.append("  </Meridian>\n  <Blades>\n")
    for index, (lines, law) in enumerate(zip(mean, thickness, strict=True)):
        kind = "main" if index == 0 else "splitter"
        out.append(f"    <Blade kind={quoteattr(kind)} leadingEdge=\"{edge[leading_edge]}\" "
                   f"trailingEdge=\"{edge[trailing_edge]}\">\n")
        out.append("      <SpanPositions>" + " ".join(f"{s:.6f}" for s in spans)
                   + "</SpanPositions>\n      <MeanLines>\n")
        for line in lines:
            rtz = np.column_stack([line[:, 0] * scale, line[:, 1], line[:, 2] * scale])
            out.append(f"        <Curve>\n{_points(rtz, ('r', 'T', 'z'), ' ' * 10)}"
                       "        </Curve>\n")
        out.append("      </MeanLines>\n      <Thickness>\n")
        xy = np.column_stack([law[:, 0], law[:, 1] * scale])
        for _ in ("hub", "shroud"):
            out.append(f"        <Curve>\n{_points(xy, ('x', 'y'), ' ' * 10)}        </Curve>\n")
        out.append("      </Thickness>\n    </Blade>\n")
    out.append("  </Blades>\n</CFturboGeometry>\n")
    return "".join(out)
