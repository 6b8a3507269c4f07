"""The whole chain (``impeller-cam run``) on each fixture: wall time and peak memory per stage.

Every fixture runs in its own child process (``impeller-cam run SPEC -m MACHINE -o
OUT/<fixture>``) with the tools and settings of its spec's ``[machining]`` table. Per
stage: wall time and peak resident memory from run.json (``VmHWM`` reset before each
stage, so native memory - OCP, VTK, numba, numpy - counts; see docs/run.md); per
fixture: the child's peak RSS (``getrusage(RUSAGE_CHILDREN).ru_maxrss`` of that child
alone, as each child is waited for before the next starts) and the stage that dominates.

Run: ``.venv/bin/python benchmarks/bench_chain.py [--fixture NAME ...] [--out DIR]
[--machine FILE]``; prints a table and writes DIR/bench_chain.json.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ("small", "nine_blade", "splitter")
STAGES = ("geometry", "rough", "finish", "post", "verify", "motion", "report")


def run_fixture(fixture: str, machine: Path, out: Path) -> dict[str, Any]:
    """Run the chain on one fixture in a child process; timings and memory."""
    exe = Path(sys.executable).parent / "impeller-cam"
    command = [str(exe), "run", str(ROOT / "fixtures" / "impellers" / fixture / "spec.toml"),
               "-m", str(machine), "-o", str(out / fixture)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    record = json.loads((out / fixture / "run.json").read_text())
    stages = {s["name"]: s for s in record["stages"]}
    ran = [s for s in record["stages"] if s["seconds"] is not None]
    # dominant by CPU time (wall time is at the mercy of other load on the machine)
    dominant = max(ran, key=lambda s: s.get("cpu_seconds") or s["seconds"])["name"] \
        if ran else None
    return {
        "fixture": fixture,
        "exit_code": done.returncode,
        "stderr": done.stderr.strip()[-500:],
        "wall_s": round(wall, 1),
        # ru_maxrss of the children is a running maximum: exact for the largest child
        "child_peak_mb": round(max(after, before) / 1024.0, 1) if after > before else None,
        "dominant_stage": dominant,
        "tools": record["tools"],
        "stages": {n: {"status": stages[n]["status"], "seconds": stages[n]["seconds"],
                       "cpu_seconds": stages[n].get("cpu_seconds"),
                       "peak_mb": stages[n]["peak_mb"]} for n in STAGES},
    }


def table(results: list[dict[str, Any]]) -> str:
    """Plain-text table: one row per stage, a (seconds, MB) column pair per fixture."""
    head = f"{'stage':<10}" + "".join(f"{r['fixture']:>30}" for r in results)
    sub = f"{'':<10}" + "".join(f"{'wall s':>10}{'cpu s':>10}{'peak MB':>10}" for _ in results)
    rows = [head, sub]
    for name in STAGES:
        row = f"{name:<10}"
        for r in results:
            s = r["stages"][name]
            sec = "-" if s["seconds"] is None else f"{s['seconds']:.1f}"
            cpu = "-" if s.get("cpu_seconds") is None else f"{s['cpu_seconds']:.1f}"
            mb = "-" if s["peak_mb"] is None else f"{s['peak_mb']:.0f}"
            if s["status"] == "failed":
                sec += "!"
            row += f"{sec:>10}{cpu:>10}{mb:>10}"
        rows.append(row)
    rows.append(f"{'total':<10}" + "".join(f"{r['wall_s']:>10.1f}{'':>20}" for r in results))
    rows.append(f"{'peak MB':<10}" + "".join(f"{str(r['child_peak_mb']):>30}" for r in results))
    rows.append(f"{'dominant':<10}" + "".join(f"{str(r['dominant_stage']):>30}"
                                              for r in results))
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixture", action="append", choices=FIXTURES,
                        help="fixture(s) to run (default: all)")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "bench_chain")
    parser.add_argument("--machine", type=Path,
                        default=ROOT / "fixtures" / "machines" / "trunnion-500.toml")
    args = parser.parse_args()
    results = []
    for fixture in args.fixture or list(FIXTURES):
        result = run_fixture(fixture, args.machine, args.out)
        results.append(result)
        print(f"{fixture}: exit {result['exit_code']}, {result['wall_s']:.1f} s, dominant "
              f"stage {result['dominant_stage']}", flush=True)
        if result["exit_code"]:
            print(f"  {result['stderr']}", flush=True)
    print(table(results))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_chain.json").write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
