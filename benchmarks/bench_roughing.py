"""Whole roughing run per fixture: wall time, UMRs, checks, Table 1 (nominal and limited).

Run: ``.venv/bin/python benchmarks/bench_roughing.py [--coarse] [--fixture NAME ...]
[--baseline-layering depth]``.

``--baseline-layering depth`` gives the five-axis baseline the 3+2 plan's layers by
milling depth instead of the paper's eq. 2 layers (docs/roughing.md, session 9): the
comparison with the layering alike.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from cam.roughing.command import run_rough
from cam.roughing.options import RoughOptions
from cam.roughing.report import table1_markdown

CASES = {"nine_blade": "ball10", "splitter": "ball6", "small": "ball6"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coarse", action="store_true",
                        help="2 mm stations, 1 mm scallop (the acceptance test's options)")
    parser.add_argument("--fixture", action="append", choices=sorted(CASES),
                        help="fixture(s) to run (default: all)")
    parser.add_argument("--baseline-layering", choices=("ruling", "depth"), default="ruling",
                        help="layers of the five-axis baseline (default: eq. 2, the paper's)")
    args = parser.parse_args()
    options: dict[str, Any] = {"step_along_mm": 2.0, "scallop_mm": 1.0} if args.coarse else {}
    options["baseline_layering"] = args.baseline_layering
    for fixture in args.fixture or list(CASES):
        tool = CASES[fixture]
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            doc = run_rough(f"fixtures/impellers/{fixture}/spec.toml",
                            "fixtures/machines/trunnion-500.toml", tool, Path(tmp) / "o",
                            progress=False, compare=True,
                            options=RoughOptions(**options))
            wall = time.perf_counter() - start
        poses = sum(op["poses"] for op in doc["operations"])
        print(f"{fixture} {tool}: {wall:.1f} s, UMRs {len(doc['umrs'])}, poses {poses}, "
              f"collisions {doc['collisions']} (postures {doc['postures_checked']}, moves "
              f"{doc['moves_checked']}, index {doc['index_moves_checked']}), min allowance "
              f"{doc['min_allowance_mm']:.4f} mm, baseline collisions "
              f"{doc['baseline_collisions']}/{doc['baseline_moves_checked']}")
        print(table1_markdown(doc))


if __name__ == "__main__":
    main()
