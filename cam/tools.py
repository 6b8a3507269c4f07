"""Cutting tools as data: cutter, shank and holder as a stack of revolved segments.

A tool library is a TOML file of ``[[tool]]`` tables (format in docs/formats.md);
LinuxCNC tool tables (``.tbl``) are read too. A ``Tool`` is described in its own
frame: tip at the origin, axis +Z towards the spindle, lengths in mm.

The outline is a list of ``Segment`` frusta (radius ``r0`` at height ``z0`` to
``r1`` at ``z1``) for the shank and holder; the cutter is a ball, flat or bull-nose
end of radius R with corner radius rc, up to the flute length. Its flutes are a
cylinder of radius R, or a cone of half-angle ``flute_taper_deg`` tangent to the
corner arc (a tapered ball-end mill, the flank milling cutter of impeller shops):
``r(h) = flank_r0 + h tan(alpha)`` above ``flank_start``. This is the one tool
model: the collision meshes (``cam.collision.tool_mesh``), the verifier's swept
primitives (``cam.verify.toolshape``) and the flank of swarf finishing
(``cam.finishing.flank_tool``) are all built from it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cam.tools_schema import ToolLibraryFile, ToolTable
from impeller_cam.data import data_path
from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml, validate

TOOL_SHAPES = ("ball", "flat", "bullnose")
#: The library shipped with the project; ``-t NAME`` looks here.
DEFAULT_LIBRARY = data_path("tools", "library.toml")


@dataclass(frozen=True)
class Segment:
    """A frustum of the tool outline along its axis.

    Attributes
    ----------
    part : str
        ``"shank"`` or ``"holder"``.
    z0, z1 : float
        Heights above the tip, mm, ``z0 < z1``.
    r0, r1 : float
        Radii at ``z0`` and ``z1``, mm.
    """

    part: str
    z0: float
    z1: float
    r0: float
    r1: float


@dataclass(frozen=True)
class Tool:
    """A cutting tool in its holder.

    Attributes
    ----------
    name : str
    number : int
        Tool number (T word, APT ``LOADTL``).
    shape : str
        ``"ball"``, ``"flat"`` or ``"bullnose"``.
    diameter : float
        Cutter diameter, mm.
    corner_radius : float
        Corner radius, mm (diameter/2 for a ball, 0 for a flat end mill).
    flute_length : float
        Cutting length from the tip, mm.
    shank_diameter : float
        Shank diameter, mm.
    stickout : float
        Gauge length from the tip to the holder nose, mm.
    holder : tuple of Segment
        Holder frusta from the nose upwards (heights from the tip).
    spindle_rpm : float or None
    feed : float or None
        Cutting feed, mm/min.
    taper_deg : float
        Half-angle of a tapered neck between flutes and shank, deg (0: straight).
    flute_taper_deg : float
        Half-angle of the flutes themselves, deg (0: cylindrical flutes). The cone is
        tangent to the corner arc; ``diameter`` is the diameter at the tip.
    """

    name: str
    number: int
    shape: str
    diameter: float
    corner_radius: float
    flute_length: float
    shank_diameter: float
    stickout: float
    holder: tuple[Segment, ...] = field(default_factory=tuple)
    spindle_rpm: float | None = None
    feed: float | None = None
    taper_deg: float = 0.0
    flute_taper_deg: float = 0.0

    @property
    def radius(self) -> float:
        """Cutter radius R at the tip (the ball radius of a ball end mill), mm."""
        return 0.5 * self.diameter

    @property
    def flute_half_angle(self) -> float:
        """Half-angle alpha of the flutes, rad (0: cylindrical)."""
        return math.radians(self.flute_taper_deg)

    @property
    def flank_start(self) -> float:
        """Height where the corner arc meets the flutes' side, mm.

        ``rc (1 - sin(alpha))``: the cone of half-angle alpha is tangent to the corner
        arc there (``rc`` for cylindrical flutes, 0 for a flat end).
        """
        return self.corner_radius * (1.0 - math.sin(self.flute_half_angle))

    @property
    def flank_r0(self) -> float:
        """Radius of the flutes' side extrapolated to the tip plane ``h = 0``, mm.

        ``R - rc + rc / cos(alpha) - rc tan(alpha)``; for a tapered ball
        ``R_b / cos(alpha) - R_b tan(alpha)``.
        """
        a = self.flute_half_angle
        rc = self.corner_radius
        return self.radius - rc + rc / math.cos(a) - rc * math.tan(a)

    def flank_radius_at(self, height: NDArray[np.float64]) -> NDArray[np.float64]:
        """Radius of the flutes' side (cylinder or cone) at heights above the tip, mm.

        Parameters
        ----------
        height : (...) float64
            Heights above the tip, mm (the line is extended beyond the flutes).

        Returns
        -------
        (...) float64
            ``flank_r0 + h tan(alpha)``, mm.
        """
        h = np.asarray(height, dtype=np.float64)
        return np.asarray(self.flank_r0 + h * math.tan(self.flute_half_angle))

    @property
    def flute_top_radius(self) -> float:
        """Radius of the cutter at the top of the flutes, mm."""
        return float(self.flank_radius_at(np.array(self.flute_length)))

    @property
    def length(self) -> float:
        """Height of the top of the holder above the tip, mm."""
        return self.holder[-1].z1 if self.holder else self.stickout

    def shank_segments(self) -> tuple[Segment, ...]:
        """Neck/shank frusta from the top of the flutes to the holder nose.

        Returns
        -------
        tuple of Segment
            Frusta ``(r0, z0, r1, z1)`` above the tip, mm.
        """
        r = self.flute_top_radius
        rs = 0.5 * self.shank_diameter
        z = self.flute_length
        segments: list[Segment] = []
        if self.taper_deg > 0 and rs > r:
            rise = (rs - r) / math.tan(math.radians(self.taper_deg))
            top = min(z + rise, self.stickout)
            r_top = r + (top - z) * math.tan(math.radians(self.taper_deg))
            segments.append(Segment("shank", z, top, r, r_top))
            z, r = top, r_top
        if self.stickout > z:
            segments.append(Segment("shank", z, self.stickout, rs, rs))
        return tuple(segments)

    def radius_at(self, height: NDArray[np.float64]) -> NDArray[np.float64]:
        """Outline radius of the cutter part at heights above the tip, mm.

        Parameters
        ----------
        height : (n,) float64
            Heights above the tip, mm, 0 <= h <= flute_length.

        Returns
        -------
        (n,) float64
            Radius of the cutter's outline at each height, mm: the corner arc below
            ``flank_start``, the flutes' side above.
        """
        h = np.asarray(height, dtype=np.float64)
        r, rc = self.radius, self.corner_radius
        inner = r - rc
        below = np.clip(rc - h, 0.0, rc)
        corner = inner + np.sqrt(np.maximum(rc * rc - below * below, 0.0))
        return np.where(h >= self.flank_start, self.flank_radius_at(h), corner)

    def outline(self, samples: int = 16) -> NDArray[np.float64]:
        """The tool's outline from the tip to the top of the holder.

        Parameters
        ----------
        samples : int
            Points on the corner (ball or bull-nose) arc.

        Returns
        -------
        (k, 2) float64
            ``(radius, height above the tip)``, mm.
        """
        heights = np.linspace(0.0, self.flank_start, samples)
        points = [np.column_stack([self.radius_at(heights), heights])]
        if self.corner_radius == 0:
            points.insert(0, np.array([[0.0, 0.0]]))
        points.append(np.array([[self.flute_top_radius, self.flute_length]]))
        for seg in (*self.shank_segments(), *self.holder):
            points.append(np.array([[seg.r0, seg.z0], [seg.r1, seg.z1]]))
        return np.vstack(points)


def _tool_from_table(table: ToolTable, path: Path, index: int) -> Tool:
    """A ``Tool`` from a validated ``[[tool]]`` table (cross-field checks here)."""
    where = f"tool {table.name!r}"
    radius = 0.5 * table.diameter_mm
    corner = {"ball": radius, "flat": 0.0}.get(table.type, table.corner_radius_mm or 0.0)
    if table.type == "bullnose" and corner >= radius:
        raise InputError(
            "bull-nose corner radius must be smaller than the radius",
            file=path,
            field=f"{where}.corner_radius_mm",
            value=corner,
            accepted=f"0 < corner < {radius:g}",
        )
    flute, stickout = table.flute_length_mm, table.stickout_mm
    if stickout < flute or flute < corner:
        raise InputError(
            "stick-out must cover the flutes and the flutes the corner",
            file=path,
            field=f"{where}.stickout_mm",
            value=stickout,
            accepted=f"corner {corner:g} <= flute {flute:g} <= stick-out",
        )
    holder: list[Segment] = []
    z = stickout
    for part in table.holder:
        holder.append(Segment("holder", z, z + part.length_mm, 0.5 * part.bottom, 0.5 * part.top))
        z += part.length_mm
    return Tool(
        name=table.name,
        number=index + 1 if table.number is None else table.number,
        shape=table.type,
        diameter=table.diameter_mm,
        corner_radius=corner,
        flute_length=flute,
        shank_diameter=table.shank_diameter_mm or table.diameter_mm,
        stickout=stickout,
        holder=tuple(holder),
        spindle_rpm=table.spindle_rpm,
        feed=table.feed_mm_min,
        taper_deg=table.taper_deg,
        flute_taper_deg=table.flute_taper_deg,
    )


def load_tool_library(path: str | Path) -> dict[str, Tool]:
    """Read a TOML tool library (``[[tool]]`` tables) or a LinuxCNC ``.tbl``.

    The TOML form is validated against ``cam.tools_schema.ToolLibraryFile``: an
    unknown key (``[[tool.holdr]]``), a wrong type, a NaN or a non-positive length is
    an ``InputError`` naming the tool, the key and the nearest valid key.

    Parameters
    ----------
    path : str or Path
        ``.toml`` library or LinuxCNC ``.tbl`` tool table (lengths mm).

    Returns
    -------
    dict
        Tools by name (LinuxCNC tools are named ``T<number>``).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(
            "tool library not found",
            file=path,
            value=str(path),
            accepted="a TOML tool library or a LinuxCNC .tbl file",
        )
    if path.suffix == ".tbl":
        return read_linuxcnc_tbl(path)
    library = validate(ToolLibraryFile, load_toml(path, "tool library"), path)
    tools: dict[str, Tool] = {}
    for i, table in enumerate(library.tool):
        tool = _tool_from_table(table, path, i)
        if tool.name in tools:
            raise InputError(
                "duplicate tool name",
                file=path,
                field=f"tool[{i}].name",
                value=tool.name,
                accepted="unique names",
            )
        tools[tool.name] = tool
    return tools


_TBL_WORD = re.compile(r"([TPDZXYR])\s*([-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)", re.IGNORECASE)


def read_linuxcnc_tbl(path: Path) -> dict[str, Tool]:
    """Read a LinuxCNC tool table: ``T<n> P<pocket> D<diameter> Z<length> ;comment``.

    LinuxCNC tables carry no shape or holder: a tool whose comment contains
    ``ball`` is a ball end mill, others flat; the flute length is taken as twice
    the diameter and the stick-out as the Z length (or 4 diameters when Z is 0).
    """
    tools: dict[str, Tool] = {}
    for line_number, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        body, _, comment = raw.partition(";")
        words = {k.upper(): float(v) for k, v in _TBL_WORD.findall(body)}
        if not body.strip():
            continue
        if "T" not in words or "D" not in words or words["D"] <= 0:
            raise InputError(
                "a tool line needs T and a positive D",
                file=path,
                field=f"line {line_number}",
                value=raw.strip(),
                accepted="T<number> P<pocket> D<diameter> [Z<length>] [;comment]",
            )
        number, diameter = int(words["T"]), words["D"]
        ball = "ball" in comment.lower()
        stickout = words.get("Z", 0.0) or 4.0 * diameter
        tools[f"T{number}"] = Tool(
            name=f"T{number}",
            number=number,
            shape="ball" if ball else "flat",
            diameter=diameter,
            corner_radius=0.5 * diameter if ball else 0.0,
            flute_length=min(2.0 * diameter, stickout),
            shank_diameter=diameter,
            stickout=stickout,
        )
    if not tools:
        raise InputError("no tools in table", file=path, accepted="lines T<n> P<n> D<d>")
    return tools


def resolve_tool(argument: str, library: str | Path | None = None) -> Tool:
    """Resolve a ``-t`` argument: ``NAME``, ``LIBRARY.toml:NAME`` or ``LIBRARY.toml``.

    A bare ``NAME`` is looked up in ``library`` (default: the bundled library). A
    library path without a name must hold exactly one tool.

    Parameters
    ----------
    argument : str
        ``NAME``, ``LIBRARY.toml:NAME`` or ``LIBRARY.toml`` (or ``.tbl``).
    library : str or Path, optional
        The library of a bare name (default: fixtures/tools/library.toml).

    Returns
    -------
    Tool
        Lengths in mm.

    Raises
    ------
    InputError
        An unknown name or library, a bad library file.
    """
    path_part, _, name = argument.rpartition(":") if ":" in argument else ("", "", argument)
    if not path_part and Path(argument).suffix in {".toml", ".tbl"}:
        path_part, name = argument, ""
    tools = load_tool_library(Path(path_part) if path_part else Path(library or DEFAULT_LIBRARY))
    source = path_part or str(library or DEFAULT_LIBRARY)
    if not name:
        if len(tools) != 1:
            raise InputError(
                "the library holds several tools: name one",
                file=source,
                field="-t",
                value=argument,
                accepted=f"{argument}:NAME with NAME in {', '.join(sorted(tools))}",
            )
        return next(iter(tools.values()))
    if name not in tools:
        raise InputError(
            "no such tool", file=source, field="-t", value=name, accepted=", ".join(sorted(tools))
        )
    return tools[name]
