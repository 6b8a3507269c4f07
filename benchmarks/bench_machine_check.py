"""CPU cost of the machine-model check against the verification's own work.

For each NC program: CPU seconds (``time.process_time``, this process, all threads)
of the verification core (``program_moves`` + ``Stock.sweep`` of every sub-move, as
``run_verify`` does) and of ``check_program`` (the machine model), on the same stock.
Programs run in the order given on one stock, as ``verify`` runs them.

Usage (from the repository root)::

    IMPELLER_CAM_THREADS=1 PYTHONPATH=. python benchmarks/bench_machine_check.py \
        MACHINE.toml TOOL STOCK PROGRAM.ngc... [--resolution 0.1]

``STOCK`` as for ``impeller-cam verify --stock`` (a spec's blank, a stock.npz...).
Prints one Markdown row per program and the totals.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from cam.tools import resolve_tool
from cam.verify.command import BATCH
from cam.verify.machine_check import check_program, machine_scene_for
from cam.verify.motion import program_moves
from cam.verify.sources import load_stock
from cam.verify.toolshape import tool_shape
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import read_nc


def _sweep(stock, moves, shape) -> None:  # type: ignore[no-untyped-def]
    ids = moves.block.astype(np.int32)
    for s in range(0, len(moves.tips), BATCH):
        e = min(len(moves.tips), s + BATCH)
        stock.sweep(moves.tips[s:e], moves.moves[s:e], moves.axes[s:e], ids[s:e], shape)


def main() -> None:
    parser = argparse.ArgumentParser(description="CPU of the machine check vs verification")
    parser.add_argument("machine", type=Path)
    parser.add_argument("tool")
    parser.add_argument("stock")
    parser.add_argument("programs", type=Path, nargs="+")
    parser.add_argument("--resolution", type=float, default=0.1)
    args = parser.parse_args()
    machine = load_machine(args.machine)
    kins = kinematics_for(machine)
    tool = resolve_tool(args.tool)
    shape = tool_shape(tool)
    stock = load_stock(args.stock, args.resolution)
    scene = machine_scene_for(machine, tool, stock)
    assert scene is not None, "the machine file has no [model]"
    total = np.zeros(2)
    print("| program | blocks | sub-moves | samples | fcl queries | verify CPU s | "
          "machine CPU s | share |")
    print("|---|---|---|---|---|---|---|---|")
    for path in args.programs:
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
