"""Verification outputs: offscreen renders, report.html, verify.json and JUnit XML.

All writers take plain data (meshes, dicts, events) and return bytes or text; the
command stages them into the output folder atomically. Renders use pyvista
offscreen (no display needed); HTML embeds the PNGs as base64 so the page is one
self-contained file.
"""

from __future__ import annotations

import base64
import html
import json
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np
from numpy.typing import NDArray

from cam.verify.events import EVENT_TYPES, Event

#: Standard views: name -> (camera direction from the focal point, view-up).
VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "iso": ((1.0, -1.0, 0.8), (0.0, 0.0, 1.0)),
    "top": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "front": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
}
IMAGE_SIZE = (800, 600)


def render_mesh(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    view: str = "iso",
    scalars: NDArray[np.float64] | None = None,
    limit: float = 0.1,
    title: str = "",
) -> bytes:
    """PNG bytes of a mesh from a standard view; ``scalars`` (per vertex, mm) are drawn
    with a diverging colour map clipped at ``+-limit`` (blue: gouge, red: excess)."""
    import pyvista as pv

    pv.OFF_SCREEN = True
    try:  # VTK warns about a missing X display before falling back to offscreen EGL/OSMesa
        from vtkmodules.vtkCommonCore import vtkObject

        vtkObject.GlobalWarningDisplayOff()
    except ImportError:  # pragma: no cover - vtk layout without vtkmodules
        pass
    plotter = pv.Plotter(off_screen=True, window_size=list(IMAGE_SIZE))
    plotter.set_background("white")  # type: ignore[call-arg, arg-type]
    if len(faces):
        cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
        mesh = pv.PolyData(np.asarray(vertices, np.float64), cells)
        if scalars is not None:
            mesh.point_data["deviation mm"] = np.asarray(scalars, np.float64)
            plotter.add_mesh(
                mesh, scalars="deviation mm", cmap="coolwarm", clim=[-limit, limit],
                smooth_shading=True, scalar_bar_args={"color": "black", "title": "deviation mm"},
            )
        else:
            plotter.add_mesh(mesh, color="#b8c4d0", smooth_shading=True, specular=0.3)
        direction, up = VIEWS[view]
        centre = np.asarray(mesh.center)
        size = float(np.linalg.norm(np.ptp(np.asarray(vertices), axis=0))) or 1.0
        plotter.camera.focal_point = centre
        plotter.camera.position = centre + 2.0 * size * np.asarray(direction) / np.linalg.norm(
            direction
        )
        plotter.camera.up = up
        plotter.reset_camera()  # type: ignore[call-arg]
    if title:
        plotter.add_text(title, font_size=10, color="black")
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return _png(np.asarray(image))


def _png(image: NDArray[np.uint8]) -> bytes:
    """Encode an (h, w, 3) uint8 image as PNG (matplotlib's writer)."""
    import io

    import matplotlib.image

    buffer = io.BytesIO()
    matplotlib.image.imsave(buffer, image, format="png")
    return buffer.getvalue()


def verify_json(result: dict[str, Any]) -> str:
    """verify.json text: sorted keys, two-space indent, trailing newline."""
    return json.dumps(result, indent=2, sort_keys=True) + "\n"


def junit_xml(programs: list[str], events: list[Event], runtime_s: float) -> str:
    """JUnit XML: one test case per program and event type; a case fails when it has
    events (each listed in the failure text with its line)."""
    cases = []
    failures = 0
    for program in programs:
        for kind in EVENT_TYPES:
            found = [e for e in events if e.program == program and e.type == kind]
            name = quoteattr(f"{kind}")
            classname = quoteattr(f"verify.{program}")
            if found:
                failures += 1
                lines = "\n".join(f"line {e.line}: {e.message}" for e in found)
                cases.append(
                    f"    <testcase classname={classname} name={name}>\n"
                    f"      <failure message={quoteattr(f'{len(found)} {kind} event(s)')}"
                    f" type={quoteattr(kind)}>{escape(lines)}</failure>\n"
                    f"    </testcase>"
                )
            else:
                cases.append(f"    <testcase classname={classname} name={name}/>")
    total = len(programs) * len(EVENT_TYPES)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<testsuites tests="{total}" failures="{failures}">\n'
        f'  <testsuite name="impeller-cam verify" tests="{total}" failures="{failures}" '
        f'errors="0" time="{runtime_s:.3f}">\n' + "\n".join(cases) + "\n  </testsuite>\n"
        "</testsuites>\n"
    )


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">' \
        f"<figcaption>{html.escape(alt)}</figcaption></figure>"


def report_html(result: dict[str, Any], images: list[tuple[str, bytes]]) -> str:
    """Self-contained report.html: summary table, events, embedded renders."""
    rows = [
        ("Programs", ", ".join(p["name"] for p in result["programs"])),
        ("Tool", result["tool"]),
        ("Machine", result["machine"]),
        ("Resolution", f"{result['resolution_mm']} mm"),
        ("Initial stock volume", f"{result['initial_volume_mm3']:.1f} mm³"),
        ("Removed volume", f"{result['removed_volume_mm3']:.1f} mm³"),
        ("Remaining volume", f"{result['remaining_volume_mm3']:.1f} mm³"),
        ("Cycle time", f"{result['cycle_time_s'] / 60.0:.2f} min"),
        ("Events", str(len(result["events"]))),
    ]
    clearances = [
        f"{p['name']}: {p['machine_clearance_mm']:.2f} mm "
        f"({' - '.join(p['machine_clearance_pair'])}, line {p['machine_clearance_line']})"
        for p in result["programs"] if p.get("machine_clearance_mm") is not None]
    if clearances:
        rows.append(("Smallest machine clearance", "; ".join(clearances)))
    if result.get("deviation"):
        dev = result["deviation"]
        if dev.get("samples"):
            rows.append(
                ("Deviation", f"min {dev['min_mm']:.3f} mm, max {dev['max_mm']:.3f} mm, "
                 f"mean |d| {dev['mean_abs_mm']:.3f} mm")
            )
    table = "\n".join(
        f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows
    )
    shown = result["events"][:500]
    event_rows = "\n".join(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.4g}</td><td>{}</td></tr>".format(
            html.escape(e["program"]), html.escape(e["type"]), e["line"], e["amount"],
            html.escape(e["message"]),
        )
        for e in shown
    )
    more = len(result["events"]) - len(shown)
    note = f"<p>{more} more events in verify.json.</p>" if more > 0 else ""
    figures = "\n".join(_img(png, caption) for caption, png in images)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>impeller-cam verification</title>
<style>
body {{ font-family: sans-serif; margin: 2em; color: #222; }}
table {{ border-collapse: collapse; margin-bottom: 1.5em; }}
th, td {{ border: 1px solid #ccc; padding: 4px 8px; text-align: left; }}
figure {{ display: inline-block; margin: 0 1em 1em 0; }}
img {{ max-width: 800px; border: 1px solid #ddd; }}
</style></head><body>
<h1>Offscreen verification</h1>
<table>{table}</table>
<h2>Events</h2>
<table><tr><th>Program</th><th>Type</th><th>Line</th><th>Amount</th><th>Message</th></tr>
{event_rows}</table>{note}
<h2>Renders</h2>
{figures}
</body></html>
"""
