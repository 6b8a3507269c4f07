"""Proxy of LinuxCNC's impeller demo for the sweep engine: its first N sub-moves.

The demo's blank (``fixtures/nc/thirdparty``) at 0.1 mm, the program's sub-moves within
0.01 mm (``run_verify``'s default), tool ball4_long, one thread; the sweep's CPU seconds
only (no reading, casting or sub-move generation). The engine is whichever ``cam`` the
checkout given as ROOT holds, so two checkouts run side by side compare engines:

    python benchmarks/bench_demo_proxy.py /work/wt/base7e 10000
    python benchmarks/bench_demo_proxy.py . 10000

Prints CPU seconds, microseconds per sub-move and the removed volume.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

DEMO = Path(
    "/usr/share/doc/linuxcnc/examples/sample-configs/sim/axis/vismach/5axis/"
    "table-rotary-tilting/demos/impeller-7bl-xyzac.ngc"
)


def main(root: Path, n: int) -> None:
    """Sweep the first ``n`` sub-moves of the demo with the engine under ``root``."""
    sys.path.insert(0, str(root))
    from cam.tools import resolve_tool
    from cam.verify.motion import program_moves
    from cam.verify.sources import load_stock
    from cam.verify.toolshape import tool_shape
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc

    third = root / "fixtures" / "nc" / "thirdparty"
    machine = load_machine(root / "fixtures" / "machines" / "xyzac-trt.toml")
    shape = tool_shape(resolve_tool(f"{third / 'tools.toml'}:ball4_long"))
    moves = program_moves(read_nc(DEMO), machine, kinematics_for(machine), shape.reach, 0.01)
    blank = str(third / "impeller-7bl-blank.stl")
    warm = load_stock(blank, 2.0)  # compile outside the timing
    warm.threads = 1
    warm.sweep(moves.tips[:50], moves.moves[:50], moves.axes[:50],
               np.arange(50, dtype=np.int32), shape)
    stock = load_stock(blank, 0.1)
    stock.threads = 1
    before = stock.volume()
    cpu = time.process_time()
    for s in range(0, n, 20000):  # run_verify's batch
        e = min(n, s + 20000)
        stock.sweep(moves.tips[s:e], moves.moves[s:e], moves.axes[s:e],
                    np.arange(s, e, dtype=np.int32), shape)
    cpu = time.process_time() - cpu
    print(f"{root}: {n} sub-moves, {cpu:.2f} s CPU, {1e6 * cpu / n:.1f} us a sub-move, "
          f"removed {before - stock.volume():.4f} mm3")


if __name__ == "__main__":
    main(Path(sys.argv[1]).resolve(), int(sys.argv[2]))
