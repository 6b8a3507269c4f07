"""BladeGen / TurboGrid curve files: a ``.inf`` file plus hub, shroud and profile curves.

The ``.inf`` file holds ``Key: value`` lines (``!`` starts a comment line); the
curve files hold whitespace-separated cartesian ``X Y Z`` lines in the ``.inf``'s
``Geometry Units``. Hub and shroud curves are meridional polylines (any angle per
point: only ``z`` and ``r`` are used). The profile file holds one block per span,
hub to shroud, each opened by a ``#`` line (``# Profile 1 at 0.0000%``) and closed
(the first point repeated at the end).

Splitters (``Number of Blades Per Set: 2``): the profile file holds the main
blade's blocks, hub to shroud, then the splitter's, with the same number of spans;
the splitter's blocks carry ``Blade 1`` in their ``#`` line. Format and sources:
docs/import-export.md.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from geometry.exchange.model import AeroBlade, AeroBlading, length_factor
from geometry.exchange.sections import split_section
from impeller_cam.errors import InputError

__all__ = ["EDGE_KEYS", "read_bladegen", "bladegen_texts"]

Array = NDArray[np.float64]
#: BladeGen edge treatments and the spec's edge shapes.
EDGE_KEYS = {"ellipseend": "round", "cutoffend": "cut"}
_SPAN = re.compile(r"at\s+([-+0-9.eE]+)\s*%")
_REQUIRED = ("axis of rotation", "number of blade sets", "number of blades per set",
             "geometry units", "hub data file", "shroud data file", "profile data file")


@dataclass
class _Entry:
    value: str
    line: int


def _read_inf(path: Path) -> dict[str, _Entry]:
    if not path.is_file():
        raise InputError("file not found", file=path, value=str(path),
                         accepted="an existing BladeGen .inf file")
    keys: dict[str, _Entry] = {}
    for number, raw in enumerate(path.read_text(encoding="utf-8", errors="replace")
                                 .splitlines(), start=1):
        text = raw.strip()
        if not text or text.startswith("!"):
            continue
        if ":" not in text:
            raise InputError(f"line {number}: not a 'Key: value' line", file=path,
                             value=text[:60], accepted="Key: value, or a '!' comment")
        key, value = text.split(":", 1)
        keys[" ".join(key.lower().split())] = _Entry(value.strip(), number)
    for key in _REQUIRED:
        if key not in keys:
            raise InputError(f"missing key '{key.title()}'", file=path, field=key.title(),
                             accepted="every key of a BladeGen export: " + ", ".join(
                                 k.title() for k in _REQUIRED))
    return keys


def _integer(path: Path, keys: dict[str, _Entry], key: str, allowed: range) -> int:
    entry = keys[key]
    try:
        value = int(entry.value)
    except ValueError:
        value = -1
    if value not in allowed:
        raise InputError(f"line {entry.line}: unsupported value", file=path, field=key.title(),
                         value=entry.value,
                         accepted=f"an integer from {allowed.start} to {allowed.stop - 1}")
    return value


def _edge(path: Path, keys: dict[str, _Entry], key: str, default: str,
          notes: list[str]) -> str:
    entry = keys.get(key)
    if entry is None:
        notes.append(f"'{key.title()}' not given: {default} assumed")
        return default
    shape = EDGE_KEYS.get(entry.value.lower())
    if shape is None:
        raise InputError(f"line {entry.line}: unsupported edge treatment", file=path,
                         field=key.title(), value=entry.value, accepted="EllipseEnd or CutOffEnd")
    return shape


def _data_file(path: Path, keys: dict[str, _Entry], key: str) -> Path:
    entry = keys[key]
    target = (path.parent / entry.value).resolve()
    if not target.is_file():
        raise InputError(f"line {entry.line}: data file not found", file=path,
                         field=key.title(), value=entry.value,
                         accepted=f"an existing curve file (relative to {path.parent})")
    return target


def _read_points(path: Path) -> list[tuple[int, str | None, list[tuple[int, Array]]]]:
    """Blocks of ``(line, '#' text or None, [(line, xyz)])`` of a curve file."""
    blocks: list[tuple[int, str | None, list[tuple[int, Array]]]] = []
    for number, raw in enumerate(path.read_text(encoding="utf-8", errors="replace")
                                 .splitlines(), start=1):
        text = raw.strip()
        if not text:
            continue
        if text.startswith("#"):
            blocks.append((number, text, []))
            continue
        cells = text.split()
        try:
            xyz = np.array([float(c) for c in cells], dtype=np.float64)
        except ValueError:
            xyz = np.array([np.nan])
        if len(cells) != 3 or not np.all(np.isfinite(xyz)):
            raise InputError(f"line {number}: not a point", file=path, value=text[:60],
                             accepted="three numbers X Y Z (or a '#' line opening a block)")
        if not blocks:
            blocks.append((number, None, []))
        blocks[-1][2].append((number, xyz))
    return blocks


def _meridional(path: Path, scale: float, what: str) -> Array:
    points = [p for _, _, block in _read_points(path) for p in block]
    if len(points) < 4:
        raise InputError(f"the {what} curve has {len(points)} points", file=path,
                         accepted="at least 4 points X Y Z")
    xyz = np.array([p for _, p in points]) * scale
    return np.column_stack([xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1])])


def _profiles(path: Path, scale: float, per_set: int) -> tuple[list[list[Array]], list[float]]:
    blocks = [b for b in _read_points(path) if b[2]]
    for line, head, _ in blocks:
        if head is None:
            raise InputError(f"line {line}: points before the first '#' line", file=path,
                             accepted="blocks each opened by a '#' line (# Profile 1 at 0%)")
    if not blocks or len(blocks) % per_set:
        raise InputError(f"{len(blocks)} profile blocks for {per_set} blade(s) per set",
                         file=path, accepted=f"a multiple of {per_set}: the main blade's "
                         "blocks hub to shroud" + (", then the splitter's" if per_set == 2 else ""))
    spans = len(blocks) // per_set
    if spans < 2:
        raise InputError(f"line {blocks[0][0]}: only {spans} span(s) per blade", file=path,
                         accepted="at least two profile blocks (hub and shroud) per blade")
    loops: list[Array] = []
    for k, (line, _, points) in enumerate(blocks):
        last_line = points[-1][0]
        first = k - k % spans
        if len(points) != len(blocks[first][2]):
            raise InputError(f"line {line}: profile block {k + 1} has {len(points)} points, "
                             f"block {first + 1} has {len(blocks[first][2])}", file=path,
                             accepted="the same number of points in every profile block of "
                             "a blade")
        xyz = np.array([p for _, p in points]) * scale
        size = float(np.ptp(xyz, axis=0).max())
        if len(xyz) < 6 or np.linalg.norm(xyz[-1] - xyz[0]) > 1e-6 * max(size, 1.0):
            raise InputError(f"line {last_line}: profile block {k + 1} (opened at line {line}) "
                             "is not closed", file=path,
                             value=" ".join(f"{v:g}" for v in points[-1][1]),
                             accepted="a closed loop: the block's first point repeated at its "
                             "end (and at least 6 points)")
        loops.append(xyz[:-1])
    percent = []
    for _, head, _ in blocks[:spans]:
        match = _SPAN.search(head or "")
        percent.append(float(match.group(1)) / 100.0 if match else float("nan"))
    if not all(np.isfinite(percent)) or np.any(np.diff(percent) <= 0):
        percent = list(np.linspace(0.0, 1.0, spans))
    return [loops[i * spans:(i + 1) * spans] for i in range(per_set)], percent


def _oriented(contour: Array) -> Array:
    """A contour from inlet to outlet: the outlet is the end with the larger radius."""
    return contour[::-1].copy() if contour[-1, 1] < contour[0, 1] else contour


def read_bladegen(path: str | Path) -> AeroBlading:
    """Read a BladeGen ``.inf`` and its curve files into an :class:`AeroBlading`.

    Raises
    ------
    InputError
        A missing key or data file, an axis other than Z, an unknown unit, blade sets
        of other than one or two blades, a block not closed, fewer than two spans,
        blocks of different point counts (each names the file and line).
    """
    path = Path(path)
    keys = _read_inf(path)
    axis = keys["axis of rotation"]
    if axis.value.strip().upper() != "Z":
        raise InputError(f"line {axis.line}: unsupported axis of rotation", file=path,
                         field="Axis of Rotation", value=axis.value,
                         accepted="Z (rotate the data so the impeller turns about Z)")
    unit = keys["geometry units"]
    scale = length_factor(unit.value, path, unit.line)
    sets = _integer(path, keys, "number of blade sets", range(1, 65))
    per_set = _integer(path, keys, "number of blades per set", range(1, 3))
    hub = _oriented(_meridional(_data_file(path, keys, "hub data file"), scale, "hub"))
    shroud = _oriented(_meridional(_data_file(path, keys, "shroud data file"), scale, "shroud"))
    profile = _data_file(path, keys, "profile data file")
    notes: list[str] = []
    le = _edge(path, keys, "blade 0 le", "round", notes)
    te = _edge(path, keys, "blade 0 te", "cut", notes)
    loops, spans = _profiles(profile, scale, per_set)
    blades = []
    for index, blade_loops in enumerate(loops):
        b_le = le if index == 0 or "blade 1 le" not in keys else \
            _edge(path, keys, "blade 1 le", le, notes)
        b_te = te if index == 0 or "blade 1 te" not in keys else \
            _edge(path, keys, "blade 1 te", te, notes)
        lines, laws = [], []
        for loop in blade_loops:
            split = split_section(loop, hub, b_le, b_te)
            cyl = np.column_stack([np.hypot(split.mean[:, 0], split.mean[:, 1]),
                                   np.unwrap(np.arctan2(split.mean[:, 1], split.mean[:, 0])),
                                   split.mean[:, 2]])
            lines.append(cyl)
            laws.append(np.column_stack([split.fraction, split.thickness]))
        blades.append(AeroBlade(np.array(spans), lines, laws, b_le, b_te, True))
    points = np.vstack([loop for blade_loops in loops for loop in blade_loops])
    at = np.concatenate([np.full(len(loop), span) for blade_loops in loops
                         for loop, span in zip(blade_loops, spans, strict=True)])
    return AeroBlading(path, "bladegen", unit.value.strip().upper(), path.stem, sets, hub,
                       shroud, blades, notes, points, at)


# -- writer ----------------------------------------------------------------------------
def _xyz_text(points: Array) -> str:
    return "".join(f"{x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in points)


def bladegen_texts(name: str, blades: int, unit: str, hub: Array, shroud: Array,
                   sections: list[list[Array]], spans: Array, leading_edge: str,
                   trailing_edge: str) -> dict[str, str]:
    """File name -> text of a BladeGen export.

    Parameters
    ----------
    name : str
        Base name of the files.
    blades : int
        Number of blade sets.
    unit : str
        ``M``, ``CM``, ``MM`` or ``IN``; ``hub``, ``shroud``, ``sections`` are in mm.
    hub, shroud : (k, 2) float64
        Meridional contours ``z, r``, mm.
    sections : list (per blade of the set) of list (per span, hub first) of (n, 3)
        Open loops (closing point not repeated), cartesian mm.
    spans : (s,) float64
        Span fraction of each section, 0 at the hub.
    """
    scale = 1.0 / length_factor(unit, Path(name))
    edge = {v: k for k, v in {"EllipseEnd": "round", "CutOffEnd": "cut"}.items()}
    files = {"hub": f"{name}_hub.curve", "shroud": f"{name}_shroud.curve",
             "profile": f"{name}_profile.curve"}
    inf = (
        "! BladeGen/TurboGrid curve files written by impeller-cam export "
        "(docs/import-export.md)\n"
        "Axis of Rotation: Z\n"
        f"Number of Blade Sets: {blades}\n"
        f"Number of Blades Per Set: {len(sections)}\n"
        f"Geometry Units: {unit.upper()}\n"
        f"Hub Data File: {files['hub']}\n"
        f"Shroud Data File: {files['shroud']}\n"
        f"Profile Data File: {files['profile']}\n"
        f"Blade 0 LE: {edge[leading_edge]}\n"
        f"Blade 0 TE: {edge[trailing_edge]}\n"
    )
    out = {f"{name}.inf": inf}
    for key, contour in (("hub", hub), ("shroud", shroud)):
        xyz = np.column_stack([contour[:, 1], np.zeros(len(contour)), contour[:, 0]])
        out[files[key]] = _xyz_text(xyz * scale)
    blocks = []
    for index, blade in enumerate(sections):
        tag = "" if index == 0 else f" Blade {index}"
        for k, (loop, span) in enumerate(zip(blade, spans, strict=True)):
            closed = np.vstack([loop, loop[:1]]) * scale
            blocks.append(f"# Profile {k + 1} at {100.0 * span:.4f}%{tag}\n" + _xyz_text(closed))
    out[files["profile"]] = "".join(blocks)
    return out
