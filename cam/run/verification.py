"""The verify stage: rough programs on the blank, finish programs on what they left.

Both runs check against the design (the spec), with the same dexel resolution, and
are written together into ``verify/`` (all or nothing):

* ``verify/rough``: the rough NC files with the roughing tool on the spec's blank;
  allowance = finishing allowance + roughing scallop; a blank short of the design
  (``stock_short``: the blank cuts into the part somewhere) stops the stage with an
  ``InputError`` before any block is run, nothing written;
* ``verify/finish``: the rest operation's NC files (``cam.run.rest``, if any), then
  the finish NC files, each with its tool (the finishing tool; the
  fillet program with the fillet tool), starting from the stock the rough run left
  (handed over in memory; ``verify/rough/stock.npz`` is that stock as saved);
  allowance = finishing scallop. The rest programs are not swept again: the finish
  stage's run of them on the same rough stock (``verify/rest``, its ``swept.json``)
  is taken over (``cam.verify.swept``), with the same results;
* ``verify/rest``: the finish stage's verification of the rest programs on the rough
  stock (``cam.run.rest``), kept as it was (the stock finishing planned against);
* ``verify/regions.json``: the deviation of the rough and the finished stock per face
  face group (``cam.run.regions``): the acceptance numbers (every milled face: blade
  sides, hub, fillets, leading and trailing edges, within allowance + scallop +
  gouge tolerance; the lathe-turned faces listed apart against the stock allowance).
"""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cam.run.regions import LabelledDesign, region_summary
from cam.run.stages import Context, fillet_tool, nc_programs, read_json, rough_allowance
from geometry.spec import load_spec
from impeller_cam.atomic import replace_path, write_text_atomic
from impeller_cam.tolerances import DEFAULT_TOLERANCES

if TYPE_CHECKING:
    from cam.verify.deviation import Deviation

__all__ = ["allowances", "verify_chain"]


@contextmanager
def _staged_folder(folder: Path) -> Iterator[Path]:
    """Build a folder with sub-folders in a hidden sibling; swap it in on success.

    On failure nothing changes; on success the old folder is replaced as a whole
    (``replace_path``).
    """
    folder.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{folder.name}-staging-", dir=folder.parent))
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    replace_path(stage, folder)


def allowances(ctx: Context) -> dict[str, float]:
    """Material meant to remain after roughing and after finishing, mm.

    Rough: ``stages.rough_allowance`` (eta plus the roughing scallop height); finish:
    the finishing scallop height (options as run, finish.json).
    """
    finish = read_json(ctx, "finish/finish.json", "finish")["options"]
    return {"rough": rough_allowance(ctx), "finish": float(finish["scallop_mm"])}


def verify_chain(ctx: Context) -> dict[str, Any]:
    """Run both verifications and the region analysis; returns regions.json content."""
    from cam.run.rest import REST_VERIFY
    from cam.run.rough_stock import DEVIATION, reusable_rough, stock_deviation
    from cam.tools import resolve_tool
    from cam.verify.command import VerifyOptions, run_verify
    from cam.verify.sources import load_stock
    from cam.verify.stock import Stock

    rough = [ctx.out / p["nc"] for p in nc_programs(ctx, "rough")]
    # the rest operation's programs (cam.run.rest) run first, on the rough stock
    finish_entries = nc_programs(ctx, "rest") + nc_programs(ctx, "finish")
    finish = [ctx.out / p["nc"] for p in finish_entries]
    # post.json names each program's tool; the settings give the arguments to load them
    arguments = {resolve_tool(a).name: a for a in (fillet_tool(ctx), ctx.settings.finish_tool)
                 if a is not None}
    finish_tools = [arguments.get(p["tool"], ctx.settings.finish_tool) for p in finish_entries]
    allow = allowances(ctx)
    resolution = ctx.settings.verify_resolution_mm
    tolerance = DEFAULT_TOLERANCES.gouge
    finish_radius = resolve_tool(ctx.settings.finish_tool).radius
    # the design is built once: both runs and the per-face summary share its distance
    design = LabelledDesign(ctx.spec)
    lathe = float(load_spec(ctx.spec).stock_allowance)
    with _staged_folder(ctx.out / "verify") as stage:
        # the report shows the stock after the last program of each run; the finish
        # stage's run of the same rough programs is reused (cam/run/rough_stock.py);
        # one stock through both runs: the finish run continues the rough run's final
        # state in memory (verify/rough/stock.npz is that state, written once)
        rest = ctx.out / REST_VERIFY  # the finish stage's run of the rest programs: kept
        if rest.is_dir():
            shutil.copytree(rest, stage / "rest", ignore=shutil.ignore_patterns("nc"))
        reused = reusable_rough(ctx)
        rough_deviation: Deviation | None
        if reused is not None:
            shutil.copytree(reused, stage / "rough",
                            ignore=shutil.ignore_patterns("nc", DEVIATION))
            stock = Stock.load(stage / "rough" / "stock.npz")
            # measured by the finish stage's run (read back when it matches)
            rough_deviation = stock_deviation(stock, design.distance, reused / DEVIATION)
        else:
            stock = load_stock(str(ctx.spec), resolution)
            rough_deviation = run_verify(
                rough, ctx.machine, ctx.settings.rough_tool, str(ctx.spec), ctx.spec,
                resolution, stage / "rough",
                options=VerifyOptions(allowance=allow["rough"], render_each_program=False,
                                      refuse_short_stock=True),
                progress=False, design_distance=design.distance, initial_stock=stock)
        # the rest programs' run on the same rough stock file is taken over when its
        # record matches (cam/verify/swept.py): they are not swept a second time
        finish_deviation = run_verify(
            finish, ctx.machine, finish_tools, str(ctx.out / "verify" / "rough" / "stock.npz"),
            ctx.spec, resolution, stage / "finish",
            options=VerifyOptions(allowance=allow["finish"], render_each_program=False),
            progress=False, design_distance=design.distance, initial_stock=stock,
            previous=rough_deviation,
            resume_from=rest if reused is not None and rest.is_dir() else None)
        assert rough_deviation is not None and finish_deviation is not None
        regions = {
            "format": "impeller-cam regions 2",
            "resolution_mm": resolution,
            "finish_ball_radius_mm": finish_radius,
            "rough_allowance_mm": allow["rough"],
            "rough": region_summary(design, rough_deviation, allow["rough"], tolerance,
                                    finish_radius, lathe),
            "finish": region_summary(design, finish_deviation, allow["finish"], tolerance,
                                     finish_radius, lathe),
        }
        write_text_atomic(stage / "regions.json", json.dumps(regions, indent=2) + "\n")
    return regions
