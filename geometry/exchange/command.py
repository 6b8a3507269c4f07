"""``impeller-cam import`` and ``impeller-cam export``: aero-design files in and out.

Import: read a BladeGen ``.inf`` (+ curve files) or a CFturbo ``.cft-geo``, write a
spec folder (``spec.toml``, camber CSVs, ``import_report.json``/``.txt``) that
``impeller-cam geometry``/``run`` read unchanged; all or nothing. Export: write a
spec as those files plus ``manufacturing.toml`` (what the aero formats do not hold:
bore, fillet, allowances, machining), which the import reads back.
"""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from geometry.exchange.bladegen import bladegen_texts, read_bladegen
from geometry.exchange.cftgeo import cftgeo_text, read_cftgeo
from geometry.exchange.from_spec import mean_lines, section_loops, surfaces_of
from geometry.exchange.model import UNITS, AeroBlading
from geometry.exchange.report import report_texts, solid_distance, surface_summary
from geometry.exchange.to_spec import imported_spec
from geometry.spec import load_spec
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml

__all__ = ["FORMATS", "MANUFACTURING", "run_export", "run_import"]

FORMATS = ("bladegen", "cft-geo")
#: The manufacturing TOML's tables and the keys each may hold.
MANUFACTURING = {"impeller": ("name",), "hub": ("bore_radius_mm",),
                 "blade": ("fillet_radius_mm",), "allowances": None, "machining": None}
MANUFACTURING_FILE = "manufacturing.toml"


def _say(message: str) -> None:
    if sys.stderr.isatty():
        print(f"import: {message}", file=sys.stderr)


def read_exchange(path: Path) -> AeroBlading:
    """Read ``path`` by its suffix (``.inf`` or ``.cft-geo``)."""
    name = path.name.lower()
    if name.endswith(".inf"):
        return read_bladegen(path)
    if name.endswith(".cft-geo"):
        return read_cftgeo(path)
    raise InputError("unknown exchange file type", file=path, value=path.suffix,
                     accepted="a BladeGen .inf or a CFturbo .cft-geo file")


def read_manufacturing(path: Path | None, source: Path) -> tuple[dict[str, Any], str]:
    """The manufacturing tables: ``path``, else ``manufacturing.toml`` beside ``source``."""
    if path is None:
        sibling = source.parent / MANUFACTURING_FILE
        if not sibling.is_file():
            return {}, "none (defaults)"
        path = sibling
    data = load_toml(path, "manufacturing")
    for table, value in data.items():
        if table not in MANUFACTURING or not isinstance(value, dict):
            raise InputError("unknown table", file=path, field=table,
                             accepted="tables " + ", ".join(MANUFACTURING))
        allowed = MANUFACTURING[table]
        for key in value:
            if allowed is not None and key not in allowed:
                raise InputError("unknown key", file=path, field=f"{table}.{key}",
                                 accepted=", ".join(f"{table}.{k}" for k in allowed))
    return data, str(path)


def run_import(source: Path, out: Path, *, manufacturing: Path | None = None,
               check_solid: bool = True) -> str:
    """Import ``source`` into the spec folder ``out``; return the report's text.

    Raises
    ------
    InputError
        Bad input file (nothing is written).
    """
    from geometry.figures import check_clearances
    from geometry.surfaces import build_surfaces

    blading = read_exchange(source)
    tables, origin = read_manufacturing(manufacturing, source)
    imported = imported_spec(blading, tables)
    imported.facts["manufacturing"] = origin
    with staged_directory(out) as stage:
        for name, text in imported.texts.items():
            write_text_atomic(stage / name, text)
        try:
            spec = load_spec(stage / "spec.toml")
            check_clearances(build_surfaces(spec))
        except InputError as error:
            raise InputError(f"the imported blade is not a valid impeller: {error.message}",
                             file=source, field=error.field, value=error.value,
                             accepted=error.accepted) from None
        surface = None
        if check_solid and blading.section_points is not None:
            _say("building the solid to measure the section points")
            points = blading.section_points
            spans = blading.section_spans if blading.section_spans is not None else \
                np.zeros(len(points))
            surface = surface_summary(points, spans, solid_distance(spec, points))
        texts = report_texts(blading, spec, imported.facts, surface)
        for name, text in texts.items():
            write_text_atomic(stage / name, text)
    return texts["import_report.txt"]


def _manufacturing_text(spec_path: Path) -> str:
    raw = tomllib.loads(spec_path.read_text(encoding="utf-8"))
    tables: dict[str, Any] = {"impeller": {"name": raw["impeller"].get("name",
                                                                       spec_path.parent.name)},
                              "hub": raw["hub"]}
    if "fillet_radius_mm" in raw.get("blade", {}):
        tables["blade"] = {"fillet_radius_mm": raw["blade"]["fillet_radius_mm"]}
    for key in ("allowances", "machining"):
        if key in raw:
            tables[key] = raw[key]
    return ("# What the aero exchange formats do not hold; impeller-cam import reads it\n"
            "# from beside the exchange file (or --manufacturing).\n" + tomli_w.dumps(tables))


def run_export(spec_path: Path, fmt: str, out: Path, *, unit: str = "MM",
               spans: int = 5) -> list[str]:
    """Write the spec ``spec_path`` as ``fmt`` files into ``out``; return the names.

    Raises
    ------
    InputError
        Bad spec, format, unit or span count (nothing is written).
    """
    if fmt not in FORMATS:
        raise InputError("unknown format", field="--format", value=fmt,
                         accepted=" or ".join(FORMATS))
    if unit.upper() not in UNITS:
        raise InputError("unknown unit", field="--units", value=unit,
                         accepted=", ".join(UNITS))
    if not 2 <= spans <= 101:
        raise InputError("unsupported span count", field="--spans", value=spans,
                         accepted="2 to 101 spans from hub to shroud")
    spec = load_spec(spec_path)
    _, blades = surfaces_of(spec)
    fractions = np.linspace(0.0, 1.0, spans)
    name = spec.name
    if fmt == "bladegen":
        loops = [section_loops(spec, blade, fractions) for blade in blades]
        texts = bladegen_texts(name, spec.blades, unit.upper(), spec.hub_contour,
                               spec.shroud_contour, loops, fractions, spec.leading_edge,
                               spec.trailing_edge)
    else:
        lines = [mean_lines(spec, blade, fractions) for blade in blades]
        law = np.column_stack([spec.thickness_u, spec.thickness_mm])
        texts = {f"{name}.cft-geo": cftgeo_text(name, spec.blades, unit.upper(),
                                                spec.hub_contour, spec.shroud_contour, lines,
                                                fractions, [law] * len(blades),
                                                spec.leading_edge, spec.trailing_edge)}
    texts[MANUFACTURING_FILE] = _manufacturing_text(spec_path)
    with staged_directory(out) as stage:
        for file, text in texts.items():
            write_text_atomic(stage / file, text)
    return sorted(texts)
