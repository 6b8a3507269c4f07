"""The stages of ``impeller-cam run``: each reads earlier stages' folders, writes its own.

A stage is a function ``stage(ctx) -> None`` that writes one folder under ``ctx.out``
all or nothing (``impeller_cam.atomic.staged_directory``, or the stage function it
wraps, which does the same). It reads only files of earlier stages, so any stage can
be rerun alone from the outputs on disk. Layout: docs/run.md (the contract of issue 8).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cam.run.settings import RunSettings
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.errors import InputError

__all__ = ["STAGE_FOLDERS", "STAGE_FUNCTIONS", "Context", "read_json", "stage_outputs"]

#: Finishing operations in machining order.
FINISH_ORDER = ("junction", "blade", "edge", "hub", "fillet")


@dataclass(frozen=True)
class Context:
    """What every stage gets: inputs, the output folder and the settings."""

    spec: Path
    machine: Path
    out: Path
    settings: RunSettings


def read_json(ctx: Context, relative: str, stage: str) -> dict[str, Any]:
    """An earlier stage's JSON file; ``InputError`` naming the stage when it is missing."""
    path = ctx.out / relative
    if not path.is_file():
        raise InputError(f"{relative} is missing: run the {stage} stage first",
                         file=path, field="--stage", value=stage,
                         accepted=f"an output folder where the {stage} stage is done")
    data = json.loads(path.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def geometry_stage(ctx: Context) -> None:
    """STEP, STL, geometry.json and the render (``run_geometry``)."""
    from geometry.command import run_geometry

    run_geometry(ctx.spec, ctx.out / "geometry", tessellation=ctx.settings.tessellation_mm,
                 render=True, fillets=True)


#: Roughing options the chain sets unless the spec's ``[machining.rough]`` does.
#: ``umr_layering``: the 3+2 plan's layers by milling depth (22 % shorter on nine_blade)
#: leave up to 0.5 mm more in the trailing edges' tip corners than eq. 2's; finishing
#: checks its shank and holder against the verified rough stock (``finish_stage``,
#: cam/finishing/stock_clearance.py), so the chain takes the faster plan (docs/run.md).
CHAIN_ROUGH_DEFAULTS: dict[str, Any] = {"umr_layering": "depth"}


def rough_options(ctx: Context) -> dict[str, Any]:
    """The roughing options of the chain: ``CHAIN_ROUGH_DEFAULTS`` under the settings'."""
    return {**CHAIN_ROUGH_DEFAULTS, **ctx.settings.rough}


def rough_stage(ctx: Context) -> None:
    """UMR roughing (``run_rough``) with the roughing tool (``rough_options``)."""
    from cam.roughing.command import run_rough
    from cam.roughing.options import RoughOptions

    run_rough(ctx.spec, ctx.machine, ctx.settings.rough_tool, ctx.out / "rough",
              options=RoughOptions.from_mapping(rough_options(ctx)), progress=False)


def rough_allowance(ctx: Context) -> float:
    """Material roughing is meant to leave on the faces it mills, mm: the finishing
    allowance eta plus the roughing scallop height (rough.json)."""
    rough = read_json(ctx, "rough/rough.json", "rough")
    return float(rough["finishing_allowance_mm"]) + float(rough["options"]["scallop_mm"])


def roughed_stock(ctx: Context) -> float:
    """Largest material the roughing is meant to leave on the part, mm.

    The milled faces keep ``rough_allowance``; faces roughing does not reach keep the
    blank's stock allowance over the shroud envelope (the spec). The larger of the two.
    """
    from geometry.spec import load_spec

    return max(rough_allowance(ctx), float(load_spec(ctx.spec).stock_allowance))


def finish_options(ctx: Context) -> dict[str, Any]:
    """The finishing options of the chain: shank and holder clear the roughed stock.

    When finishing runs the part still carries what roughing left. The finishing
    setting ``clearance_mm`` (default ``DEFAULT_TOLERANCES.clearance``) is therefore the
    clearance from that stock: finishing is given ``clearance_mm + roughed_stock`` from
    the design (the material roughing is meant to leave, and ``clearance_exact_mm`` at
    least that) and ``stock_clearance_mm`` (default: ``clearance_mm``) from the verified
    rough stock's material beyond it (``finish_stage``).
    """
    from cam.finishing.options import FinishOptions

    options = dict(ctx.settings.finish)
    defaults = FinishOptions()
    base = float(options.get("clearance_mm", defaults.clearance_mm))
    clearance = base + roughed_stock(ctx)
    options["stock_clearance_mm"] = float(options.get("stock_clearance_mm", base))
    options["clearance_mm"] = clearance
    options["clearance_exact_mm"] = max(
        float(options.get("clearance_exact_mm", defaults.clearance_exact_mm)), clearance)
    return options


def fillet_tool(ctx: Context) -> str | None:
    """The fillet pencil's tool: the settings' (spec's ``[machining] fillet_tool``), else
    the library's largest ball no larger than the fillet; ``None``: no fillet pass
    (no fillet, or no such ball: finish.json's ``fillet_note`` says so)."""
    from cam.finishing.fillet_plan import choose_fillet_tool
    from geometry.spec import load_spec

    if ctx.settings.fillet_tool is not None:
        return ctx.settings.fillet_tool
    chosen = choose_fillet_tool(float(load_spec(ctx.spec).fillet_radius))
    return None if chosen is None else chosen.name


def finish_stage(ctx: Context) -> None:
    """The rough programs verified (``verify_rough``), five-axis finishing (``run_finish``)
    with the finishing tool (``finish_options``) against that stock and the fillet pencil
    passes with ``fillet_tool``; where the stock left finishing postures out, the rest
    operation (``cam.run.rest.plan_rest``: ``rest/``) and finishing again against the
    stock it left, only those postures' passes planned anew (``plan_memo``). The runs
    share one design (the spec's impeller and its signed distance, built once)."""
    from cam.finishing.command import run_finish
    from cam.finishing.options import FinishOptions
    from cam.finishing.plan_memo import PlanMemo
    from cam.run.rest import finish_with_rest
    from cam.run.rough_stock import verify_rough

    rough = verify_rough(ctx)

    def finish(stock: Path, memo: PlanMemo) -> dict[str, Any]:
        return run_finish(ctx.spec, ctx.machine, ctx.settings.finish_tool, ctx.out / "finish",
                          options=FinishOptions.from_mapping(finish_options(ctx)),
                          progress=False, fillet_tool=fillet_tool(ctx), stock=stock,
                          design=rough.design, design_distance=rough.distance, memo=memo)

    finish_with_rest(ctx, rough, finish)


def apt_files(ctx: Context) -> list[tuple[str, str, str]]:
    """``(operation, apt relative path, tool name)`` of every APT file, machining order
    (rough, the rest operation's rounds, finish)."""
    rough = read_json(ctx, "rough/rough.json", "rough")
    finish = read_json(ctx, "finish/finish.json", "finish")
    out = [("rough", f"rough/{op['apt']}", rough["tool"]["name"])
           for op in rough["operations"]]
    documents = [("rest", folder, document) for folder, document in rest_finishes(ctx)]
    for stage, folder, document in [*documents, ("finish", "finish", finish)]:
        ops = document["operations"]
        order = [op for op in FINISH_ORDER if op in ops] + sorted(set(ops) - set(FINISH_ORDER))
        out += [(stage, f"{folder}/{ops[op]['apt']}",
                 ops[op].get("tool", document["tool"])["name"]) for op in order]
    return out


def rest_round_folder(round_: int) -> str:
    """Folder (relative to the output) of the rest operation's round ``round_`` (from
    1): ``rest`` for the first, ``rest/round<k>`` for the later ones (``cam.run.rest``)."""
    return "rest" if round_ == 1 else f"rest/round{round_}"


def rest_finishes(ctx: Context) -> list[tuple[str, dict[str, Any]]]:
    """``(folder, finish.json)`` of every round of the rest operation (``cam.run.rest``),
    machining order; empty when it has none."""
    found: list[tuple[str, dict[str, Any]]] = []
    while (path := ctx.out / rest_round_folder(len(found) + 1) / "finish.json").is_file():
        data = json.loads(path.read_text(encoding="utf-8"))
        assert isinstance(data, dict)
        found.append((rest_round_folder(len(found) + 1), data))
    return found


def known_collisions(finish: dict[str, Any]) -> list[str]:
    """What finish.json says still collides in the finish programs, one line each.

    Postures and moves of a path (``collisions``, ``motion_collisions``: the design,
    the in-process stock or the machine), links between passes (``link_collisions``)
    and moves the machine model hits (``machine_model``); empty when none.
    """
    found = [f"path {e['name']}: {e['collisions']} postures, {e['motion_collisions']} "
             "moves" for e in finish.get("paths", [])
             if e.get("collisions") or e.get("motion_collisions")]
    for op, entry in finish.get("operations", {}).items():
        if entry.get("link_collisions"):
            found.append(f"operation {op}: {entry['link_collisions']} link moves")
    machine = finish.get("machine_model") or {}
    for op, entry in (machine.get("operations") or {}).items():
        if entry.get("machine_collision_moves"):
            found.append(f"operation {op}: {entry['machine_collision_moves']} moves "
                         "hit the machine")
    return found


def post_stage(ctx: Context) -> None:
    """Every APT file to one NC program (machine's dialect or the chosen one), post.json.

    A finish program with a known collision (``known_collisions``) is never posted:
    ``InputError`` naming the paths, and nothing is written.
    """
    from postproc.command import post_text
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc
    from postproc.posts import get_post

    files = apt_files(ctx)  # names the first stage whose outputs are missing
    found = known_collisions(read_json(ctx, "finish/finish.json", "finish")) + [
        f"{folder} {line}" for folder, rest in rest_finishes(ctx)
        for line in known_collisions(rest)]
    if found:
        shown = "; ".join(found[:10]) + (f"; and {len(found) - 10} more"
                                         if len(found) > 10 else "")
        raise InputError(f"the finish programs still collide, not posted: {shown}",
                         file=ctx.out / "finish" / "finish.json",
                         field="collisions",
                         accepted="finish.json with 0 collisions, motion, link and machine "
                                  "collisions (finishing leaves out what it cannot free: "
                                  "cut_short)")
    machine = load_machine(ctx.machine)
    dialect = get_post(ctx.settings.post or machine.post)
    programs = []
    with staged_directory(ctx.out / "nc") as stage:
        for operation, apt, tool in files:
            text = post_text(ctx.out / apt, ctx.machine, post=dialect.name,
                             tcp=ctx.settings.tcp, post_options=ctx.settings.post_options)
            name = f"{Path(apt).stem}.{dialect.extension}"
            write_text_atomic(stage / name, text)
            blocks = len(read_nc(stage / name, machine=machine))
            programs.append({"operation": operation, "name": Path(apt).stem, "apt": apt,
                             "nc": f"nc/{name}", "blocks": blocks, "tool": tool})
        document = {"post": dialect.name, "machine": str(ctx.machine), "programs": programs}
        write_text_atomic(stage / "post.json", json.dumps(document, indent=2) + "\n")


def nc_programs(ctx: Context, operation: str | None = None) -> list[dict[str, Any]]:
    """Entries of post.json (of one operation)."""
    programs = read_json(ctx, "nc/post.json", "post")["programs"]
    return [p for p in programs if operation is None or p["operation"] == operation]


def verify_stage(ctx: Context) -> None:
    """Verification of the rough programs on the blank, then the finish programs on the
    stock they left; both against the design (the spec), plus regions.json."""
    from cam.run.verification import verify_chain

    verify_chain(ctx)


def motion_stage(ctx: Context) -> None:
    """Cycle times, UMR index-move optimisation, servo prediction (motion.json, PNGs)."""
    from cam.run.motion import motion_outputs

    motion_outputs(ctx)


def report_stage(ctx: Context) -> None:
    """report.html from the files above (``cam.report.build_report``)."""
    try:
        from cam.report import build_report  # type: ignore[attr-defined, unused-ignore]
    except ImportError as error:
        raise RuntimeError("the report stage needs cam.report.build_report, which this "
                           f"build does not have ({error})") from None
    build_report(ctx.out)


#: Stage name -> function.
STAGE_FUNCTIONS: dict[str, Callable[[Context], None]] = {
    "geometry": geometry_stage,
    "rough": rough_stage,
    "finish": finish_stage,
    "post": post_stage,
    "verify": verify_stage,
    "motion": motion_stage,
    "report": report_stage,
}
#: Stage name -> what it writes (relative to the output folder).
STAGE_FOLDERS: dict[str, tuple[str, ...]] = {
    "geometry": ("geometry",), "rough": ("rough",), "finish": ("rest", "finish"),
    "post": ("nc",),
    "verify": ("verify",), "motion": ("motion",), "report": ("report.html",),
}


def stage_outputs(out: Path, name: str) -> list[str]:
    """Relative paths of the files a stage wrote (sorted; hidden staging files left out)."""
    found: list[str] = []
    for rel in STAGE_FOLDERS[name]:
        path = out / rel
        if path.is_file():
            found.append(rel)
        elif path.is_dir():
            found += sorted(p.relative_to(out).as_posix() for p in path.rglob("*")
                            if p.is_file() and not any(part.startswith(".")
                                                       for part in p.relative_to(out).parts))
    return found
