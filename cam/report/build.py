"""``build_report(OUT)``: the process engineer's report.html of a chain run.

The report reads only the files of OUT/ (``cam.report.inputs.RunFolder``): run.json,
the stages' JSON, PNG, STL, APT, NC and stock files. Each of the eleven sections is a
``<section id=...>`` with a heading (ids in ``SECTION_IDS``); a section whose input is
missing says so ("stage verify did not run", "motion/motion.json is missing").
The page is self-contained (inline CSS, images as data: URIs, no script) and
deterministic: no timestamps beyond what run.json carries.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from cam.report.figures import (
    angles_section,
    deviation_section,
    render_section,
    stock_section,
    toolpaths_section,
)
from cam.report.html import Section, page
from cam.report.inputs import RunFolder
from cam.report.tables import cycle_time_section, indexing_section, servo_section, umr_section
from cam.report.verification import events_section, summary_section
from impeller_cam.atomic import write_text_atomic

__all__ = ["REPORT_NAME", "SECTION_IDS", "build_report", "report_html"]

REPORT_NAME = "report.html"
#: Section ids in page order (the browser test looks for each).
SECTION_IDS = ("summary", "render", "toolpaths", "stock", "deviation", "angles", "umr",
               "cycle-time", "indexing", "servo", "events")


def _builders(render: bool) -> list[Callable[[RunFolder], Section]]:
    return [
        summary_section,
        render_section,
        lambda f: toolpaths_section(f, render),
        lambda f: stock_section(f, render),
        deviation_section,
        angles_section,
        umr_section,
        cycle_time_section,
        indexing_section,
        servo_section,
        events_section,
    ]


def report_html(out: str | Path, *, render: bool = True) -> str:
    """The report page of OUT/ as text (nothing written).

    Parameters
    ----------
    out : str or Path
        The output folder of ``impeller-cam run``.
    render : bool
        Draw the pictures no stage wrote (tool paths; stock from stock.npz). Off:
        those sections keep their tables and legends (quick tests).

    Returns
    -------
    str
        The HTML page (pictures embedded).

    Raises
    ------
    InputError
        ``out`` is not a folder.
    """
    folder = RunFolder(out)
    sections = [build(folder) for build in _builders(render)]
    assert tuple(s.id for s in sections) == SECTION_IDS
    run = folder.run
    name = run.get("impeller") or run.get("name")
    spec = run.get("spec")
    if not name and spec:
        name = Path(str(spec)).parent.name or Path(str(spec)).stem
    title = f"Impeller machining report: {name}" if name else "Impeller machining report"
    machine = run.get("machine")
    subtitle = "impeller-cam run" + (f" of {spec}" if spec else "") + \
        (f" on {machine}" if machine else "")
    return page(title, subtitle, sections)


def build_report(out: Path, *, render: bool = True) -> Path:
    """Write OUT/report.html (atomically) from the files in OUT/ and return its path.

    Parameters
    ----------
    out : Path
        The output folder of ``impeller-cam run`` (run.json, geometry/, rough/,
        finish/, nc/, verify/, motion/; any of them may be missing).
    render : bool
        See ``report_html``.

    Returns
    -------
    Path
        ``OUT/report.html``.

    Raises
    ------
    InputError
        ``out`` is not a folder.
    """
    text = report_html(out, render=render)
    return write_text_atomic(Path(out) / REPORT_NAME, text)
