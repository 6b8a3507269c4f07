"""Benchmark: a whole five-axis finishing run (``impeller-cam finish``) per fixture.

For each impeller fixture: wall-clock time of ``run_finish`` (set-up of the
collision scene included), the number of paths and cutter-centre points, the
junction path point counts (the paper: 475 CC points on the pressure-side
junction, 26 paths), reverse movements of A and C before and after smoothing,
collisions left, the smallest shank/holder clearance, and postures checked per
second. The collision scene is the built solid's meshes (``--scene solid``,
default) or the closed-form surfaces (``--scene surfaces``). Run:

    .venv/bin/python benchmarks/bench_finishing.py [--fixtures small nine_blade splitter]
        [--scene solid|surfaces] [--scallop MM] [--spacing MM] [--passages N]

The numbers go to stdout; outputs to a temporary folder (``--keep DIR`` keeps them).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from cam.finishing.command import run_finish

ROOT = Path(__file__).resolve().parents[1]
TOOLS = {"small": "ball4_taper", "nine_blade": "ball6_taper", "splitter": "ball4_taper"}
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=list(TOOLS))
    parser.add_argument("--scene", default="solid", choices=("solid", "surfaces"))
    parser.add_argument("--scallop", type=float, default=0.05, help="scallop height, mm")
    parser.add_argument("--spacing", type=float, default=0.25, help="point spacing, mm")
    parser.add_argument("--passages", type=int, default=None, help="passages (default all)")
    parser.add_argument("--machine", type=Path, default=MACHINE)
    parser.add_argument("--keep", type=Path, default=None, help="keep the outputs here")
    args = parser.parse_args()
    header = (f"{'fixture':<11} {'scene':<8} {'tool':<12} {'paths':>6} {'points':>8} "
              f"{'junction pts':>14} {'A/C rev before':>15} {'after':>7} {'coll':>5} "
              f"{'min clear':>9} {'time s':>8} {'pts/s':>7}")
    print(header)
    for name in args.fixtures:
        with tempfile.TemporaryDirectory() as tmp:
            out = (args.keep / name) if args.keep else Path(tmp) / name
            start = time.perf_counter()
            doc = run_finish(ROOT / "fixtures" / "impellers" / name / "spec.toml",
                             args.machine, TOOLS[name], out, scene=args.scene,
                             progress=False, scallop_mm=args.scallop,
                             point_spacing_mm=args.spacing, passages=args.passages)
            elapsed = time.perf_counter() - start
        s = doc["summary"]
        before = f"{s['reversals_before']['A']}/{s['reversals_before']['C']}"
        after = f"{s['reversals_after']['A']}/{s['reversals_after']['C']}"
        junction = ",".join(str(n) for n in s["junction_points"][:4])
        clear = "-" if s["min_clearance_mm"] is None else f"{s['min_clearance_mm']:.3f}"
        print(f"{name:<11} {args.scene:<8} {TOOLS[name]:<12} {s['paths']:>6} {s['points']:>8} "
              f"{junction:>14} {before:>15} {after:>7} {s['collisions']:>5} {clear:>9} "
              f"{elapsed:>8.1f} {s['points'] / elapsed:>7.0f}")
        if s["smaller_tool_needed"]:
            print(f"  smaller tool needed on {len(s['smaller_tool_needed'])} paths, e.g. "
                  f"{s['smaller_tool_needed'][:3]}")
    print("paper (seed 001): 475 CC points on the pressure-side junction, 26 paths, "
          "0 reversals after tuning")


if __name__ == "__main__":
    main()
