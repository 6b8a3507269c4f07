"""OUT/sweep.html: the sweep's table, sortable, and its key plots, in one file.

Nothing is loaded at view time: the sorting is a few lines of plain JavaScript in the
page and the plots are inline SVG drawn by matplotlib (Agg). Plots:

* **cycle time against each varied numeric parameter** (blade count, angles, ...):
  roughing and finishing cycle times, min, of the variants that got that far; when
  no stage timed anything, r_max against the parameter instead;
* **feasible / infeasible map**: the first two varied parameters (one: against the
  variant's index), each variant marked done, failed (at which stage) or invalid.

The numbers are the table's (``cam.run.sweep_table.row``), i.e. those of the
variants' variant.json files.
"""

from __future__ import annotations

import html
import io
import re
from typing import Any

__all__ = ["sweep_html"]

_STATUS_STYLE = {"done": ("o", "tab:green"), "failed": ("s", "tab:orange"),
                 "invalid": ("x", "tab:red")}
_SCRIPT = """
function sortBy(th) {
  const table = th.closest('table'), body = table.tBodies[0];
  const col = Array.from(th.parentNode.children).indexOf(th);
  const up = th.dataset.dir !== 'asc';
  th.parentNode.querySelectorAll('th').forEach(h => delete h.dataset.dir);
  th.dataset.dir = up ? 'asc' : 'desc';
  const key = r => r.children[col].dataset.v ?? r.children[col].textContent;
  const rows = Array.from(body.rows);
  rows.sort((a, b) => {
    const x = key(a), y = key(b), nx = parseFloat(x), ny = parseFloat(y);
    if (x === '' || y === '') return (x === '') - (y === '');
    const c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
    return up ? c : -c;
  });
  rows.forEach(r => body.appendChild(r));
}
"""
_STYLE = """
body { font-family: sans-serif; margin: 1.5em; }
table { border-collapse: collapse; font-size: 12px; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; white-space: nowrap; }
th { background: #eee; cursor: pointer; position: sticky; top: 0; }
th[data-dir=asc]::after { content: ' \\25B2'; } th[data-dir=desc]::after { content: ' \\25BC'; }
td.text { text-align: left; }
td.text.long { white-space: normal; min-width: 24em; max-width: 40em; }
tr.invalid { background: #fde8e8; } tr.failed { background: #fff2dc; }
.plots svg { max-width: 48%; height: auto; display: inline-block; }
"""


def _numeric(rows: list[dict[str, Any]], name: str) -> bool:
    values = [r.get(name) for r in rows if r.get(name) is not None]
    return bool(values) and all(isinstance(v, int | float) and not isinstance(v, bool)
                                for v in values)


def _svg(figure: Any) -> str:
    buffer = io.StringIO()
    figure.savefig(buffer, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buffer.getvalue()
    return re.sub(r"<metadata>.*?</metadata>", "", text[text.index("<svg"):], flags=re.S)


def _cycle_plot(rows: list[dict[str, Any]], parameter: str) -> str:
    import matplotlib.pyplot as plt

    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    timed = False
    for column, label, marker in (("rough_cycle_s", "roughing", "o"),
                                  ("finish_cycle_s", "finishing", "^")):
        points = [(r[parameter], r[column] / 60.0) for r in rows
                  if r.get(column) is not None and r.get(parameter) is not None]
        if points:
            timed = True
            xs, ys = zip(*points, strict=True)
            ax.scatter(xs, ys, marker=marker, label=label)
    if timed:
        ax.set_ylabel("cycle time, min")
        ax.legend()
    else:
        points = [(r[parameter], r["r_max_mm"]) for r in rows
                  if r.get("r_max_mm") is not None and r.get(parameter) is not None]
        if points:
            xs, ys = zip(*points, strict=True)
            ax.scatter(xs, ys)
        ax.set_ylabel("r_max, mm")
    ax.set_xlabel(parameter)
    ax.grid(alpha=0.3)
    ax.set_title(f"{'cycle time' if timed else 'largest roughing ball r_max'} "
                 f"against {parameter}")
    svg = _svg(figure)
    plt.close(figure)
    return svg


def _feasibility_plot(rows: list[dict[str, Any]], parameters: list[str]) -> str:
    import matplotlib.pyplot as plt

    axes = [p for p in parameters if _numeric(rows, p)][:2]
    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    for status, (marker, colour) in _STATUS_STYLE.items():
        chosen = [(i, r) for i, r in enumerate(rows) if r["status"] == status]
        if not chosen:
            continue
        if len(axes) == 2:
            xy = [(r[axes[0]], r[axes[1]]) for _, r in chosen]
        elif len(axes) == 1:
            xy = [(r[axes[0]], i) for i, r in chosen]
        else:
            xy = [(i, 0) for i, _ in chosen]
        xs, ys = zip(*xy, strict=True)
        ax.scatter(xs, ys, marker=marker, color=colour, s=60,
                   label=f"{status} ({len(chosen)})")
    ax.set_xlabel(axes[0] if axes else "variant index")
    ax.set_ylabel(axes[1] if len(axes) == 2 else "variant index")
    ax.legend()
    ax.grid(alpha=0.3)
    ax.set_title("feasible (done) and infeasible variants")
    svg = _svg(figure)
    plt.close(figure)
    return svg


def _cell(value: Any) -> str:
    if value is None:
        return '<td data-v=""></td>'
    if isinstance(value, bool):
        return f'<td class="text">{"true" if value else "false"}</td>'
    if isinstance(value, float):
        return f'<td data-v="{value!r}">{value:.4g}</td>'
    if isinstance(value, int):
        return f"<td>{value}</td>"
    text = str(value)
    kind = "text long" if len(text) > 40 else "text"
    return f'<td class="{kind}">{html.escape(text)}</td>'


def sweep_html(rows: list[dict[str, Any]], names: list[str], parameters: list[str],
               summary: dict[str, Any]) -> str:
    """The page: counts, plots, the table (every column of sweep.csv)."""
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "impeller-cam-sweep"
    plots = [_cycle_plot(rows, p) for p in parameters if _numeric(rows, p)]
    plots.append(_feasibility_plot(rows, parameters))
    head = "".join(f'<th onclick="sortBy(this)">{html.escape(n)}</th>' for n in names)
    body = "".join(f'<tr class="{html.escape(r["status"])}">'
                   + "".join(_cell(r.get(n)) for n in names) + "</tr>\n" for r in rows)
    counts = ", ".join(f"{summary[k]} {k}" for k in ("done", "failed", "invalid"))
    return (
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">"
        f"<title>sweep of {html.escape(summary['design'])}</title>"
        f"<style>{_STYLE}</style><script>{_SCRIPT}</script></head><body>\n"
        f"<h1>Sweep of {html.escape(summary['design'])}</h1>\n"
        f"<p>{len(rows)} variants: {counts}. Stages: {html.escape(summary['stages'])}. "
        f"Scheduler: {html.escape(summary['scheduler'])}. Click a column head to sort. "
        "Lengths mm, volumes mm&sup3;, cycle times s (plots: min).</p>\n"
        f"<div class=\"plots\">{''.join(plots)}</div>\n"
        f"<table><thead><tr>{head}</tr></thead><tbody>\n{body}</tbody></table>\n"
        "</body></html>\n"
    )
