"""The figures of one sweep variant, read from what its stages wrote.

``variant_figures`` gathers, from the variant's folder on the worker, what an engineer
compares across variants (lengths mm, volumes mm^3, times s):

* ``design``: the design generator's figures (``spec/figures.json``: d_min, r_max,
  rule deviation, largest fillet, D2, ...);
* ``balls``: the largest ball-end mills of the tool library that the passage admits
  (``largest_balls``);
* ``geometry``: the solid's volume (``geometry/geometry.json``);
* ``rough``: tool, 3+2 collisions, rapids in stock, cycle time;
* ``finish``: tool, collisions, paths needing a smaller tool, the verification of the
  rough programs the finish stage runs (gouges, rapids in stock), cycle time;
* ``verify``: the verdicts of ``verify/regions.json`` (rough and finish accepted).

A stage that did not run gives ``None``. Cycle times are those of the motion stage
(``cam.motion.breakdown.program_file_times``: look-ahead blending under the machine's
limits): each APT file of the stage is posted with the machine's dialect (as the post
stage does) and timed.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from cam.tools import DEFAULT_LIBRARY, load_tool_library

__all__ = ["largest_balls", "program_seconds", "variant_figures"]

#: A ball this much larger than a limit still counts as within it (rounding), mm.
RADIUS_SLACK = 1e-6


def _json(path: Path) -> dict[str, Any] | None:
    if not path.is_file():
        return None
    data = json.loads(path.read_text(encoding="utf-8"))
    return data if isinstance(data, dict) else None


def _largest(balls: list[Any], low: float, high: float) -> dict[str, Any]:
    fits = [t for t in balls if low - RADIUS_SLACK <= t.radius <= high + RADIUS_SLACK]
    if not fits:
        return {"name": None, "radius_mm": None}
    best = max(t.radius for t in fits)
    tool = next(t for t in fits if t.radius == best)  # ties: the first in the library
    return {"name": tool.name, "radius_mm": float(tool.radius)}


def largest_balls(figures: dict[str, Any], library: str | Path | None = None
                  ) -> dict[str, Any]:
    """The largest roughing and finishing balls of a tool library for a design.

    * roughing: radius ``<= r_max = (d_min - 2 eta) / (2 k)`` (M4 eq. 1, the check
      ``cam.roughing.tool_size`` makes);
    * finishing: radius ``<= d_min / (2 k)`` (eq. 1 without the finishing allowance,
      which is gone when the finishing ball passes) and ``>= r_f``, the fillet radius
      (a smaller ball would cut into the fillet: docs/finishing.md, junction paths).

    Parameters
    ----------
    figures : dict
        ``design_figures`` (keys ``d_min_mm``, ``r_max_mm``, ``protection_factor_k``,
        ``fillet_radius_mm``).
    library : str or Path, optional
        Tool library (default: the bundled one).

    Returns
    -------
    dict
        ``{"rough": {"name", "radius_mm"}, "finish": {...}}``; ``None`` values when no
        ball of the library fits; ties: the first in the library.
    """
    tools = load_tool_library(Path(library or DEFAULT_LIBRARY)).values()
    balls = [t for t in tools if t.shape == "ball"]
    d_min, k = float(figures["d_min_mm"]), float(figures["protection_factor_k"])
    return {
        "rough": _largest(balls, 0.0, float(figures["r_max_mm"])),
        "finish": _largest(balls, float(figures["fillet_radius_mm"]), d_min / (2.0 * k)),
    }


def program_seconds(apts: list[Path], machine: str | Path, post: str | None,
                    operation: str) -> float:
    """Cycle time of APT files posted for ``machine``, s (sum of the programs)."""
    from cam.motion.breakdown import program_file_times
    from postproc.command import post_text
    from postproc.machine import load_machine
    from postproc.posts import get_post

    model = load_machine(machine)
    dialect = get_post(post or model.post)
    total = 0.0
    with tempfile.TemporaryDirectory(prefix="sweep-nc-") as folder:
        for apt in apts:
            nc = Path(folder) / f"{apt.stem}.{dialect.extension}"
            nc.write_text(post_text(apt, machine, post=dialect.name), encoding="utf-8")
            total += float(program_file_times(nc, apt, model, operation)["cycle_time_s"])
    return total


def _rough(out: Path, machine: Path, post: str | None) -> dict[str, Any] | None:
    rough = _json(out / "rough" / "rough.json")
    if rough is None:
        return None
    apts = [out / "rough" / op["apt"] for op in rough["operations"]]
    return {"tool": rough["tool"]["name"], "collisions": rough["collisions"],
            "rapids_in_stock": rough.get("rapids_in_stock", {}).get("3axis"),
            "min_allowance_mm": rough.get("min_allowance_mm"),
            "cycle_s": program_seconds(apts, machine, post, "rough")}


def _finish(out: Path, machine: Path, post: str | None) -> dict[str, Any] | None:
    finish = _json(out / "finish" / "finish.json")
    if finish is None:
        return None
    summary = finish["summary"]
    apts = [out / "finish" / op["apt"] for op in finish["operations"].values()]
    checked = _json(out / "verify" / "rough" / "verify.json") or {}
    events = checked.get("event_counts", {})
    return {"tool": finish["tool"]["name"], "collisions": summary["collisions"],
            "smaller_tool_needed": len(summary["smaller_tool_needed"]),
            "rough_gouges": events.get("gouge"),
            "rough_rapids_in_stock": events.get("rapid_in_stock"),
            "cycle_s": program_seconds(apts, machine, post, "finish")}


def _verify(out: Path) -> dict[str, Any] | None:
    regions = _json(out / "verify" / "regions.json")
    if regions is None:
        return None
    return {"rough_accepted": bool(regions["rough"]["accepted"]),
            "finish_accepted": bool(regions["finish"]["accepted"])}


def variant_figures(spec_folder: Path, out: Path, machine: Path, post: str | None,
                    library: str | Path | None = None) -> dict[str, Any]:
    """The figures of one variant (module docstring); ``None`` for stages not run.

    Parameters
    ----------
    spec_folder : Path
        The generated spec (``figures.json`` beside ``spec.toml``).
    out : Path
        The chain's output folder (may not exist: design-only sweep).
    machine : Path
        Machine TOML.
    post : str or None
        Post-processor (default the machine's).
    library : str or Path, optional
        Tool library of ``largest_balls``.
    """
    design = _json(spec_folder / "figures.json")
    geometry = _json(out / "geometry" / "geometry.json")
    return {
        "design": design,
        "balls": None if design is None else largest_balls(design, library),
        "geometry": None if geometry is None else {"volume_mm3": geometry["volume_mm3"]},
        "rough": _rough(out, machine, post),
        "finish": _finish(out, machine, post),
        "verify": _verify(out),
    }
