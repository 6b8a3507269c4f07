"""The sweep's table: one row per variant, written as CSV and Parquet.

Columns (``columns``): ``variant``, ``status`` (``done`` / ``invalid`` / ``failed``),
``stage`` (where a variant stopped), ``error``, then one column per varied parameter
(its ``--vary`` path), then the figures (``FIGURE_COLUMNS``: lengths mm, volume mm^3,
cycle times s, counts), each taken from the variant's ``variant.json`` (``row``), so
the table and the per-variant files agree by construction. A figure of a stage that
did not run is blank in the CSV and null in Parquet. No timings or worker names: the
same sweep gives the same table wherever it ran (they are in sweep.json).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

from impeller_cam.atomic import write_bytes_atomic, write_text_atomic

__all__ = ["FIGURE_COLUMNS", "columns", "csv_text", "row", "write_parquet"]


def _get(*keys: str) -> Callable[[dict[str, Any]], Any]:
    def pick(figures: dict[str, Any]) -> Any:
        node: Any = figures
        for key in keys:
            if not isinstance(node, dict) or node.get(key) is None:
                return None
            node = node[key]
        return node
    return pick


#: Figure column -> how it is read from ``variant.json["figures"]``.
FIGURE_COLUMNS: dict[str, Callable[[dict[str, Any]], Any]] = {
    "blades": _get("design", "blades"),
    "D2_mm": _get("design", "D2_mm"),
    "d_min_mm": _get("design", "d_min_mm"),
    "r_max_mm": _get("design", "r_max_mm"),
    "rough_ball": _get("balls", "rough", "name"),
    "rough_ball_radius_mm": _get("balls", "rough", "radius_mm"),
    "finish_ball": _get("balls", "finish", "name"),
    "finish_ball_radius_mm": _get("balls", "finish", "radius_mm"),
    "rule_deviation_mm": _get("design", "rule_deviation_mm"),
    "max_fillet_radius_mm": _get("design", "max_fillet_radius_mm"),
    "volume_mm3": _get("geometry", "volume_mm3"),
    "rough_tool": _get("rough", "tool"),
    "rough_cycle_s": _get("rough", "cycle_s"),
    "rough_collisions": _get("rough", "collisions"),
    "rough_rapids_in_stock": _get("rough", "rapids_in_stock"),
    "finish_tool": _get("finish", "tool"),
    "finish_cycle_s": _get("finish", "cycle_s"),
    "finish_collisions": _get("finish", "collisions"),
    "finish_smaller_tool_needed": _get("finish", "smaller_tool_needed"),
    "rough_verify_gouges": _get("finish", "rough_gouges"),
    "rough_accepted": _get("verify", "rough_accepted"),
    "finish_accepted": _get("verify", "finish_accepted"),
}
HEAD_COLUMNS = ("variant", "status", "stage", "error")


def columns(parameters: list[str]) -> list[str]:
    """Column names: head, the varied parameters' paths, the figures."""
    return [*HEAD_COLUMNS, *parameters, *FIGURE_COLUMNS]


def row(variant: dict[str, Any], parameters: list[str]) -> dict[str, Any]:
    """The table row of one ``variant.json`` (``None``: not run / not known)."""
    figures = variant.get("figures") or {}
    out: dict[str, Any] = {"variant": variant["name"], "status": variant["status"],
                           "stage": variant.get("stage"), "error": variant.get("error")}
    out.update({p: variant["parameters"].get(p) for p in parameters})
    out.update({name: pick(figures) for name, pick in FIGURE_COLUMNS.items()})
    return out


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def csv_text(rows: list[dict[str, Any]], names: list[str]) -> str:
    """CSV of the rows (header first; floats as their shortest round-trip text)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(names)
    for r in rows:
        writer.writerow([_cell(r.get(n)) for n in names])
    return buffer.getvalue()


def write_csv(path: Path, rows: list[dict[str, Any]], names: list[str]) -> Path:
    """Write sweep.csv atomically."""
    return write_text_atomic(path, csv_text(rows, names))


def _arrow_column(values: list[Any]) -> list[Any]:
    """One type per column: numbers as float unless all are int; others as text."""
    present = [v for v in values if v is not None]
    if all(isinstance(v, bool) for v in present):
        return values
    if all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return values
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
        return [None if v is None else float(v) for v in values]
    return [None if v is None else _cell(v) for v in values]


def write_parquet(path: Path, rows: list[dict[str, Any]], names: list[str]) -> str | None:
    """Write sweep.parquet atomically with pyarrow; the reason when it cannot.

    Returns
    -------
    str or None
        ``None`` when written; else why not (pyarrow is an optional dependency:
        ``pip install impeller-cam[parquet]``).
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return "pyarrow is not installed (pip install 'impeller-cam[parquet]'): no Parquet"
    table = pa.table({n: _arrow_column([r.get(n) for r in rows]) for n in names})
    buffer = pa.BufferOutputStream()
    pq.write_table(table, buffer)
    write_bytes_atomic(path, buffer.getvalue().to_pybytes())
    return None
