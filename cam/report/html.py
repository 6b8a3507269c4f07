"""HTML building blocks of the process report: escaping, tables, figures, the page.

Every function returns an HTML fragment (``str``). Text that comes from files is
escaped here (``html.escape``), so section builders pass plain strings and never
build markup from file content themselves. Images are embedded as base64 ``data:``
URIs; the style sheet is inline; the page needs no script and no network.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

__all__ = [
    "Cell",
    "Section",
    "checks_list",
    "definition_table",
    "figure",
    "format_number",
    "lack",
    "missing",
    "note",
    "page",
    "paragraph",
    "swatch_legend",
    "table",
]

#: A table cell: text (escaped) or a number (formatted, right-aligned) or None ("-").
Cell = str | int | float | None


@dataclass
class Section:
    """One ``<section id=...>`` of the report.

    Attributes
    ----------
    id : str
        Element id (fixed per section: the browser test looks for it).
    title : str
        Heading text.
    body : str
        HTML fragment (already escaped).
    missing : list of str
        What the section could not show (each also said in ``body``).
    """

    id: str
    title: str
    body: str
    missing: list[str] = field(default_factory=list)


def format_number(value: float | int, digits: int = 3) -> str:
    """A number for a table: integers as is, floats with ``digits`` decimals; an
    exponent when that would show no significant digit or the number is huge;
    whole floats of 1000 and more without decimals.

    >>> format_number(0.25, 1), format_number(30000.0, 4), format_number(2e-5, 3)
    ('0.2', '30000', '2.000e-05')
    """
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        return str(value)
    magnitude = abs(value)
    if magnitude != 0.0 and (magnitude < 10.0 ** -digits or magnitude >= 1e7):
        return f"{value:.{digits}e}"
    if magnitude >= 1000.0 and value == round(value):
        return f"{value:.0f}"
    return f"{value:.{digits}f}"


def _cell(value: Cell, digits: int) -> str:
    if value is None:
        return '<td class="none">-</td>'
    if isinstance(value, bool):
        return f'<td class="{"yes" if value else "no"}">{"yes" if value else "no"}</td>'
    if isinstance(value, int | float):
        return f'<td class="num">{html.escape(format_number(value, digits))}</td>'
    return f"<td>{html.escape(str(value))}</td>"


def table(headers: Sequence[str], rows: Sequence[Sequence[Cell]], *,
          digits: int | Sequence[int] = 3, caption: str = "", css: str = "") -> str:
    """A data table; numbers right-aligned with ``digits`` decimals (one for all
    columns or one per column), text escaped."""
    per_column = [digits] * len(headers) if isinstance(digits, int) else list(digits)
    if len(per_column) != len(headers):
        raise ValueError(f"digits has {len(per_column)} entries for {len(headers)} columns")
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "\n".join("<tr>" + "".join(_cell(v, d) for v, d in zip(row, per_column, strict=True))
                     + "</tr>" for row in rows)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    cls = f' class="{html.escape(css)}"' if css else ""
    return f"<table{cls}>{cap}<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody></table>"


def definition_table(rows: Sequence[tuple[str, Cell]], *, digits: int = 3) -> str:
    """A two-column key/value table (keys as row headers)."""
    body = "\n".join(f"<tr><th>{html.escape(k)}</th>{_cell(v, digits)}</tr>" for k, v in rows)
    return f'<table class="kv"><tbody>\n{body}\n</tbody></table>'


def figure(png: bytes, caption: str, *, css: str = "") -> str:
    """An ``<img>`` with the PNG inlined as a data URI, and its caption."""
    data = base64.b64encode(png).decode("ascii")
    text = html.escape(caption)
    cls = f' class="{html.escape(css)}"' if css else ""
    return (f'<figure{cls}><img alt="{text}" src="data:image/png;base64,{data}">'
            f"<figcaption>{text}</figcaption></figure>")


def paragraph(text: str) -> str:
    """A paragraph of plain (escaped) text."""
    return f"<p>{html.escape(text)}</p>"


def note(text: str) -> str:
    """A small explanatory note (where the numbers come from)."""
    return f'<p class="note">{html.escape(text)}</p>'


def missing(text: str) -> str:
    """A visible notice that an input is missing (never a silent blank)."""
    return f'<p class="missing">{html.escape(text)}</p>'


def lack(parts: list[str], lost: list[str], text: str) -> None:
    """Say in ``parts`` that an input is missing (``missing``) and record it in ``lost``."""
    lost.append(text)
    parts.append(missing(text))


def checks_list(checks: Sequence[tuple[str, bool | None, str]]) -> str:
    """Pass/fail cards: (name, passed or None when unknown, detail text)."""
    cards = []
    for name, passed, detail in checks:
        state, word = ("pass", "PASS") if passed else ("fail", "FAIL")
        if passed is None:
            state, word = "unknown", "NOT CHECKED"
        cards.append(f'<div class="check {state}"><span class="verdict">{word}</span>'
                     f'<span class="name">{html.escape(name)}</span>'
                     f'<span class="detail">{html.escape(detail)}</span></div>')
    return '<div class="checks">' + "\n".join(cards) + "</div>"


def swatch_legend(entries: Sequence[tuple[str, str]]) -> str:
    """A colour legend: (label, ``#rrggbb``) pairs as coloured swatches."""
    items = "".join(
        f'<li><span class="swatch" style="background:{html.escape(colour)}"></span>'
        f"{html.escape(label)}</li>" for label, colour in entries)
    return f'<ul class="legend">{items}</ul>'


STYLE = """
:root { --ink: #1d2733; --muted: #5b6673; --line: #d5dbe1; --band: #f3f5f7;
        --accent: #1f5f99; --ok: #1e7b34; --bad: #b3261e; --unk: #8a6d00; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", "Helvetica Neue", Arial, sans-serif; color: var(--ink);
       margin: 0; background: #fff; font-size: 14px; line-height: 1.45; }
header { background: var(--accent); color: #fff; padding: 18px 32px 14px; }
header h1 { margin: 0 0 4px; font-size: 24px; font-weight: 600; }
header p { margin: 0; opacity: 0.92; }
nav { padding: 8px 32px; background: var(--band); border-bottom: 1px solid var(--line);
      display: flex; flex-wrap: wrap; gap: 4px 16px; }
nav a { color: var(--accent); text-decoration: none; white-space: nowrap; }
main { padding: 0 32px 32px; max-width: 1320px; }
section { border-bottom: 1px solid var(--line); padding: 10px 0 18px; }
h2 { font-size: 19px; margin: 14px 0 8px; color: var(--accent); }
h3 { font-size: 15px; margin: 12px 0 6px; }
table { border-collapse: collapse; margin: 6px 0 12px; font-size: 13px; }
caption { text-align: left; font-weight: 600; padding: 4px 0; }
th, td { border: 1px solid var(--line); padding: 3px 8px; text-align: left;
         vertical-align: top; }
thead th { background: var(--band); }
table.kv th { background: var(--band); font-weight: 600; width: 15em; }
table.kv td { max-width: 560px; overflow-wrap: anywhere; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.none { color: var(--muted); text-align: center; }
td.yes { color: var(--ok); } td.no { color: var(--bad); font-weight: 600; }
td code, p code { font-family: "DejaVu Sans Mono", monospace; font-size: 12px; }
.cols { display: flex; flex-wrap: wrap; gap: 24px; align-items: flex-start; }
figure { display: inline-block; margin: 4px 12px 12px 0; vertical-align: top; }
figure img { max-width: 100%; border: 1px solid var(--line); display: block; }
figure.wide { width: 1000px; } figure.half { width: 600px; } figure.third { width: 400px; }
figure.wide img, figure.half img, figure.third img { width: 100%; }
figcaption { color: var(--muted); font-size: 12px; margin-top: 3px; }
p.note { color: var(--muted); font-size: 12px; margin: 4px 0 8px; }
p.missing { background: #fff4e5; border-left: 4px solid var(--unk); padding: 6px 10px;
            margin: 6px 0; }
.checks { display: flex; flex-wrap: wrap; gap: 10px; margin: 8px 0 12px; }
.check { border: 1px solid var(--line); border-left-width: 6px; padding: 6px 10px;
         min-width: 250px; max-width: 420px; background: #fff; }
.check .verdict { font-weight: 700; margin-right: 8px; }
.check .name { font-weight: 600; }
.check .detail { display: block; color: var(--muted); font-size: 12px; }
.check.pass { border-left-color: var(--ok); } .check.pass .verdict { color: var(--ok); }
.check.fail { border-left-color: var(--bad); } .check.fail .verdict { color: var(--bad); }
.check.unknown { border-left-color: var(--unk); } .check.unknown .verdict { color: var(--unk); }
ul.legend { list-style: none; padding: 0; margin: 4px 0 8px; display: flex;
            flex-wrap: wrap; gap: 4px 16px; }
ul.legend li { display: flex; align-items: center; gap: 6px; }
.swatch { display: inline-block; width: 22px; height: 8px; border: 1px solid #888; }
.status-done { color: var(--ok); font-weight: 600; }
.status-failed { color: var(--bad); font-weight: 600; }
.status-notrun { color: var(--muted); }
p.verdict { font-size: 16px; font-weight: 700; margin: 4px 0 6px; }
p.verdict.pass { color: var(--ok); } p.verdict.fail { color: var(--bad); }
p.verdict.unknown { color: var(--unk); }
details { margin: 6px 0; }
details > summary { cursor: pointer; font-weight: 600; padding: 3px 0; }
@media print { nav { display: none; } section { break-inside: avoid-page; } }
"""


def page(title: str, subtitle: str, sections: Sequence[Section]) -> str:
    """The whole document: header, section navigation, sections, inline CSS."""
    links = "".join(f'<a href="#{html.escape(s.id)}">{html.escape(s.title)}</a>'
                    for s in sections)
    body = "\n".join(
        f'<section id="{html.escape(s.id)}">\n<h2>{html.escape(s.title)}</h2>\n{s.body}\n'
        "</section>" for s in sections)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n"
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<style>{STYLE}</style></head>\n<body>\n"
        f"<header><h1>{html.escape(title)}</h1><p>{html.escape(subtitle)}</p></header>\n"
        f"<nav>{links}</nav>\n<main>\n{body}\n</main>\n</body></html>\n"
    )
