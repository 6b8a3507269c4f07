"""CPU cost of the machine-model check against the verification's own work.

For each NC program: CPU seconds (``time.process_time``, this process, all threads)
of the verification core (``program_moves`` + ``Stock.sweep`` of every sub-move, as
``run_verify`` does) and of ``check_program`` (the machine model), on the same stock.
The stock is swept, so programs run in order as the chain runs them.

Usage (from the repository root; a chain's output folder with nc/ and verify/)::

    IMPELLER_CAM_THREADS=1 PYTHONPATH=. python benchmarks/bench_machine_check.py \\
        OUT MACHINE.toml SPEC.toml [--resolution 0.1]

Prints one row per program and the totals; the rough program runs on the spec's
blank with the spec's roughing tool, the finish programs on verify/rough/stock.npz
with the finishing tool.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from cam.tools import resolve_tool
from cam.verify.command import BATCH
from cam.verify.machine_check import check_program, machine_scene_for
from cam.verify.motion import program_moves
from cam.verify.sources import load_stock
from cam.verify.toolshape import tool_shape
from geometry.spec import load_spec
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import read_nc


def _sweep(stock, moves, shape) -> None:  # type: ignore[no-untyped-def]
    ids = moves.block.astype(np.int32)
    for s in range(0, len(moves.tips), BATCH):
        e = min(len(moves.tips), s + BATCH)
        stock.sweep(moves.tips[s:e], moves.moves[s:e], moves.axes[s:e], ids[s:e], shape)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("machine", type=Path)
    parser.add_argument("spec", type=Path)
    parser.add_argument("--resolution", type=float, default=0.1)
    args = parser.parse_args()
    machine = load_machine(args.machine)
    kins = kinematics_for(machine)
    spec = load_spec(args.spec)
    post = json.loads((args.out / "nc" / "post.json").read_text())
    runs = {"rough": [], "finish": []}  # type: dict[str, list[Path]]
    for entry in post["programs"]:
        name = Path(entry["nc"]).name
        runs["rough" if name.startswith("rough") else "finish"].append(args.out / entry["nc"])
    stocks = {"rough": str(args.spec), "finish": str(args.out / "verify/rough/stock.npz")}
    tools = {"rough": spec.machining.rough_tool or "ball10",
             "finish": spec.machining.finish_tool or "ball6_taper"}
    total = np.zeros(2)
    print("| program | blocks | sub-moves | samples | fcl queries | verify CPU s | "
          "machine CPU s | share |")
    print("|---|---|---|---|---|---|---|---|")
    for label in ("rough", "finish"):
        tool = resolve_tool(tools[label])
        shape = tool_shape(tool)
        stock = load_stock(stocks[label], args.resolution)
        scene = machine_scene_for(machine, tool, stock)
        assert scene is not None, "the machine file has no [model]"
        for path in runs[label]:
            program = read_nc(path)
            t0 = time.process_time()
            moves = program_moves(program, machine, kins, shape.reach, 0.1 * stock.pitch)
            _sweep(stock, moves, shape)
            t1 = time.process_time()
            check = check_program(scene, kins, program, path.name)
            t2 = time.process_time()
            total += (t1 - t0, t2 - t1)
            print(f"| {path.name} | {len(program)} | {len(moves.tips)} | {check.samples} | "
                  f"{check.exact} | {t1 - t0:.1f} | {t2 - t1:.1f} | "
                  f"{100 * (t2 - t1) / (t1 - t0):.1f} % |", flush=True)
    print(f"| total | | | | | {total[0]:.1f} | {total[1]:.1f} | "
          f"{100 * total[1] / total[0]:.1f} % |")


if __name__ == "__main__":
    main()
