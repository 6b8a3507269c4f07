"""Swarf blade finishing measured: the verifier against the prediction, cycle time (issue 23).

Stages (each writes under ``OUT/FIXTURE/``; run them in order):

* ``finish``: ``run_finish`` on passage 0 (solid scene) with ``--strategy``
  (``swarf_or_point``, ``swarf`` or ``point``), the tool ``-t``, the production
  tolerances of ``bench_finishing.py --production`` (scallop 0.01 mm, chordal 0.01 mm,
  the spec's spacing as the cap; clearance as the main job's), no hub passes and no
  edge passes unless ``--edge-passes`` (``--as-every-passage``: the blade passes
  trimmed as in a run of every passage, see ``edge_cover``); every APT posted for
  trunnion-500 (its own dialect) into ``nc/``.
* ``verify``: (the prediction re-made with the options of the finish stage's
  finish.json) the verifier's own pieces on ``nc/finish_swarf.ngc``: the tool's swept
  primitives (``toolshape``), the program's sub-moves (``program_moves``, sweep
  tolerance ``--sweep-tol``, the chain's 0.01 mm by default; ``--angular-tol``: the
  APT posted again with that angular tolerance, deg) swept through a tri-dexel
  stock at ``--resolution`` (``--stock``: a ``stock.npz`` such as the main job's
  rough stock, or the spec's blank), then the stock surface samples the swarf
  program made, measured on each pass's band against the exact side and the
  verifier's design mesh and compared with the prediction
  (``cam.finishing.swarf_verify.measure_passes``).
* ``cycle``: the product's cycle-time model (the motion stage's: exact stop at every
  block, ``cycle_time_s``, and blended within G64 P, ``blended_s``) of every NC
  program of the run.

Run: ``python benchmarks/bench_swarf.py STAGE FIXTURE -t TOOL --out DIR [...]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
PRODUCTION = {"scallop_mm": 0.01, "chordal_tolerance_mm": 0.01}


def spec_path(fixture: str) -> Path:
    return ROOT / "fixtures" / "impellers" / fixture / "spec.toml"


def finish_stage(fixture: str, tool: str, strategy: str, out: Path,
                 clearance: float | None, ruling_step: float | None = None,
                 edges: bool = False, every_passage: bool = False) -> None:
    import tomllib

    from cam.finishing.command import run_finish
    from postproc.command import run_post

    doc = tomllib.loads(spec_path(fixture).read_text())
    options: dict[str, Any] = dict(doc.get("machining", {}).get("finish", {}))
    options.update(PRODUCTION)
    if clearance is not None:
        options["clearance_mm"] = clearance
        options["clearance_exact_mm"] = max(3.0, clearance)
    options.update(passages=1, hub_passes=False, edge_passes=edges, blade_strategy=strategy)
    if ruling_step is not None:
        options["swarf_ruling_step_mm"] = ruling_step
    if every_passage:  # the trims of a run of every passage (passage 0 planned only)
        import cam.finishing.command as command

        setattr(command, "edge_cover_turns", lambda options, blades: (-1, 0, 1))  # noqa: B010
    wall, cpu = time.perf_counter(), time.process_time()
    result = run_finish(spec_path(fixture), MACHINE, tool, out / "finish", plots=False,
                        machine_obstacle=False, **options)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    (out / "nc").mkdir(parents=True, exist_ok=True)
    for op in result["operations"]:
        run_post(out / "finish" / f"finish_{op}.apt", MACHINE, out / "nc" / f"finish_{op}.ngc")
    print(json.dumps({"stage": "finish", "fixture": fixture, "tool": tool,
                      "strategy": strategy, "options": options, "wall_s": round(wall, 1),
                      "cpu_s": round(cpu, 1), "swarf": result.get("swarf"),
                      "summary": result.get("summary"),
                      "link_collisions": result.get("link_collisions"),
                      "operations": {k: v["poses"] for k, v in result["operations"].items()}},
                     default=str))


def verify_stage(fixture: str, tool_name: str, out: Path, stock_arg: str, resolution: float,
                 sweep_tol: float, clearance: float | None,
                 angular_tol: float | None = None) -> None:
    from cam.finishing.options import FinishOptions
    from cam.finishing.swarf_plan import swarf_walls
    from cam.finishing.swarf_verify import measure_passes, passes_of_program
    from cam.tools import resolve_tool
    from cam.verify.command import _sweep_program
    from cam.verify.deviation import DesignDistance
    from cam.verify.motion import program_moves
    from cam.verify.sources import load_design, load_stock
    from cam.verify.toolshape import tool_shape
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces
    from postproc.apt import read_apt
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc

    tool = resolve_tool(tool_name)
    spec = load_spec(spec_path(fixture))
    surfaces = build_surfaces(spec)
    # the prediction with the options the finish stage planned with (ruling step,
    # tolerances, clearance as flute margin)
    fields: dict[str, Any] = json.loads((out / "finish" / "finish.json").read_text())["options"]
    if clearance is not None and clearance != fields["clearance_mm"]:
        raise SystemExit(f"--clearance {clearance} differs from the finish stage's "
                         f"{fields['clearance_mm']}")
    walls = swarf_walls(surfaces, tool, FinishOptions.from_mapping(fields))
    tips = np.vstack([tp.tip for tp in read_apt(out / "finish" / "finish_swarf.apt")])
    passes = passes_of_program(walls, tips)
    machine = load_machine(MACHINE)
    kins = kinematics_for(machine)
    ngc = out / "nc" / "finish_swarf.ngc"
    if angular_tol is not None:  # posted again, the axis held within angular_tol deg
        from postproc.command import run_post

        ngc = out / "nc" / f"finish_swarf_a{angular_tol:g}.ngc"
        run_post(out / "finish" / "finish_swarf.apt", MACHINE, ngc,
                 angular_tolerance_deg=angular_tol)
    program = read_nc(ngc, machine=machine)
    shape = tool_shape(tool)
    t0 = time.perf_counter()
    stock = load_stock(stock_arg if stock_arg != "blank" else str(spec_path(fixture)),
                       resolution)
    earlier = len(stock.owners)
    moves = program_moves(program, machine, kins, shape.reach, sweep_tol)
    _sweep_program(stock, moves, shape, earlier, None, ngc.name)
    points, _, made = stock.surface_samples()
    mine = made >= earlier
    vertices, faces, _ = load_design(spec_path(fixture))
    report: dict[str, Any] = {"stage": "verify", "fixture": fixture, "tool": tool_name,
                              "stock": stock_arg, "resolution_mm": resolution,
                              "program": ngc.name, "blocks": len(program.line),
                              "sweep_tolerance_mm": sweep_tol, "sub_moves": len(moves.tips),
                              "swarf_samples": int(mine.sum()), "passes": []}
    design = DesignDistance(vertices, faces)
    everywhere = design(points[mine])  # gouges anywhere the swarf program cut
    report["all_samples_min_mm"] = float(everywhere.min())
    report["gouges"] = int((everywhere < -0.05).sum())
    collected: list[np.ndarray] = []
    found = measure_passes(walls, passes, points[mine], spec.leading_edge, spec.trailing_edge,
                           design=design, collect=collected)
    np.savez_compressed(out / f"samples_{ngc.stem}.npz", *collected)
    report["passes"] = [m.as_dict() for m in found]
    report["largest_difference_mm"] = max((m.difference for m in found), default=None)
    report["wall_s"] = round(time.perf_counter() - t0, 1)
    (out / f"verify_{ngc.stem}.json").write_text(json.dumps(report, indent=1))
    print(json.dumps(report))


def cycle_stage(out: Path) -> None:
    """Every NC program's cycle time under the motion stage's model
    (``cam.motion.breakdown.program_file_times``), s: ``cycle_time_s`` a jerk-limited
    stop at every block (as before), ``blended_s`` blended within the program's G64 P,
    and the nominal time."""
    from cam.motion.breakdown import program_file_times
    from postproc.machine import load_machine

    machine = load_machine(MACHINE)
    times = {}
    for ngc in sorted((out / "nc").glob("*.ngc")):
        found = program_file_times(ngc, out / "finish" / ngc.with_suffix(".apt").name,
                                   machine)
        times[ngc.name] = {"cycle_time_s": round(float(found["exact_stop_s"]), 2),
                           "blended_s": round(float(found["cycle_time_s"]), 2),
                           "nominal_time_s": round(float(found["nominal_s"]), 2),
                           "blocks": int(found["blocks"])}
    (out / "cycle.json").write_text(json.dumps(times, indent=1))
    print(json.dumps({"stage": "cycle", "out": str(out), "programs": times}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("stage", choices=["finish", "verify", "cycle"])
    parser.add_argument("fixture")
    parser.add_argument("-t", "--tool", default="ball6_flank3")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--strategy", default="swarf_or_point")
    parser.add_argument("--clearance", type=float, default=None)
    parser.add_argument("--ruling-step", type=float, default=None,
                        help="finish: swarf_ruling_step_mm (default: the spec's, else 1 mm)")
    parser.add_argument("--edge-passes", action="store_true",
                        help="finish: plan the edge passes too (swarf_or_point leaves the "
                             "blade points they finish to them)")
    parser.add_argument("--as-every-passage", action="store_true",
                        help="finish, with --edge-passes: passage 0's blade passes trimmed "
                             "as in a run of every passage (the neighbours' edge passes, "
                             "passage 0's turned, finish its walls' edge ends)")
    parser.add_argument("--stock", default="blank")
    parser.add_argument("--resolution", type=float, default=0.1)
    parser.add_argument("--sweep-tol", type=float, default=0.01)
    parser.add_argument("--angular-tol", type=float, default=None,
                        help="verify: post finish_swarf.apt again at this angular tolerance, deg")
    args = parser.parse_args()
    out = args.out / args.fixture
    if args.stage == "finish":
        finish_stage(args.fixture, args.tool, args.strategy, out, args.clearance,
                     args.ruling_step, args.edge_passes, args.as_every_passage)
    elif args.stage == "verify":
        verify_stage(args.fixture, args.tool, out, args.stock, args.resolution,
                     args.sweep_tol, args.clearance, args.angular_tol)
    else:
        cycle_stage(out)


if __name__ == "__main__":
    main()
