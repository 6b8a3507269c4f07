"""The process engineer's report of a chain run: ``build_report(OUT) -> OUT/report.html``.

Modules: ``inputs`` (reading OUT/), ``html`` (escaping, tables, figures, the page),
``verification`` (summary, events), ``figures`` (impeller, tool paths, stock,
deviation, A/C plots), ``tables`` (UMRs, cycle times, indexing, servo), ``renders``
(pyvista pictures), ``build`` (the page). docs/report.md says what each section shows
and where its numbers come from.
"""

from cam.report.build import REPORT_NAME, SECTION_IDS, build_report, report_html

__all__ = ["REPORT_NAME", "SECTION_IDS", "build_report", "report_html"]
