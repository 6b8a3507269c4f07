"""Cross-dialect verification of a chain's own programs (issue 21's acceptance).

The chain output folder's APT files (``rough/rough.apt`` and ``finish/*.apt``, the
tools from ``nc/post.json``) are posted in six forms -- LinuxCNC (M428 TCP),
Sinumerik (TRAORI with tool vectors, TRAORI with rotary positions, CYCLE800 frames
for the 3+2 roughing) and Heidenhain (FUNCTION TCPM, PLANE SPATIAL for the 3+2
roughing) -- and each form's programs are verified in sequence on the spec's blank
(``run_verify``, one tool per program, the design for gouges, the machine model).
Printed and written to ``OUT/cross_dialect.json``: per form and program the removed
volume, its relative difference to LinuxCNC's, the events (type, count) and whether
the events fall on corresponding blocks (block index in the program's own reading).

Run: ``python benchmarks/cross_dialect.py out/nine_blade -m
fixtures/machines/trunnion-500.toml --spec fixtures/impellers/nine_blade/spec.toml
--resolution 0.5 -o /tmp/cross``.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

FORMS: dict[str, tuple[str, str, dict[str, str]]] = {
    "linuxcnc": ("linuxcnc", "ngc", {}),
    "sinumerik_vectors": ("sinumerik", "mpf", {"orientation": "vector"}),
    "sinumerik_rotary": ("sinumerik", "mpf", {}),
    "sinumerik_cycle800": ("sinumerik", "mpf", {"frames": "cycle800"}),
    "heidenhain_tcpm": ("heidenhain", "h", {}),
    "heidenhain_plane": ("heidenhain", "h", {"frames": "plane-spatial"}),
}


def _programs(chain: Path) -> list[tuple[str, Path, str]]:
    """(name, APT file, tool) of every program the chain posted, in its order."""
    post = json.loads((chain / "nc" / "post.json").read_text())
    return [(p["name"], chain / p["apt"], p["tool"]) for p in post["programs"]]


def _block_events(programs: list[Path], report: dict[str, Any], machine: Path
                  ) -> list[tuple[int, str, int]]:
    """(program index, event type, block index) of every event, sorted."""
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc

    the_machine = load_machine(machine)
    names = [p.name for p in programs]
    lines = {p.name: read_nc(p, machine=the_machine).line for p in programs}
    found = []
    for event in report["events"]:
        at = lines[event["program"]]
        block = int(np.searchsorted(at, event["line"]))
        found.append((names.index(event["program"]), event["type"], block))
    return sorted(found)


def compare(results: dict[str, Any]) -> None:
    """Add each form's differences to LinuxCNC's and print them.

    ``excess`` events are the listing of the largest leftovers (capped per program):
    a removed volume that differs in the sixth digit can swap which samples make the
    list, so they are compared by count, and the share of listed ones found at the
    same block is printed; every other event must be at the same block.
    """
    reference = results.get("linuxcnc")
    if reference is None:
        return
    ref_volumes = np.array(reference["volumes_mm3"])
    ref_events = [tuple(e) for e in reference["block_events"]]
    for key, result in results.items():
        rel = np.abs(np.array(result["volumes_mm3"]) - ref_volumes) / ref_volumes
        events = [tuple(e) for e in result["block_events"]]
        strict = [e for e in events if e[1] != "excess"]
        result["volume_rel_diff_max"] = float(rel.max())
        result["same_events_at_same_blocks"] = strict == [e for e in ref_events
                                                          if e[1] != "excess"]
        excess = Counter(e for e in events if e[1] == "excess")
        ref_excess = Counter(e for e in ref_events if e[1] == "excess")
        result["excess_counts_equal"] = (Counter(e[0] for e in excess.elements())
                                         == Counter(e[0] for e in ref_excess.elements()))
        result["excess_same_block_share"] = (sum((excess & ref_excess).values())
                                             / max(1, sum(ref_excess.values())))
        print(f"{key:20s} max rel volume diff {rel.max():.2e}  other events at the same "
              f"blocks: {result['same_events_at_same_blocks']}  excess counts equal: "
              f"{result['excess_counts_equal']} ({result['excess_same_block_share']:.1%} "
              f"at the same block)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("chain", type=Path, help="chain output folder (impeller-cam run -o)")
    parser.add_argument("-m", "--machine", type=Path, required=True)
    parser.add_argument("--spec", type=Path, required=True)
    parser.add_argument("--resolution", type=float, default=0.5)
    parser.add_argument("--forms", default=",".join(FORMS))
    parser.add_argument("-o", "--out", type=Path, required=True)
    parser.add_argument("--compare-only", action="store_true",
                        help="re-read OUT/cross_dialect.json and compare again")
    args = parser.parse_args()
    if args.compare_only:
        saved = json.loads((args.out / "cross_dialect.json").read_text())
        compare(saved["forms"])
        (args.out / "cross_dialect.json").write_text(json.dumps(saved, indent=1))
        return

    from cam.verify.command import VerifyOptions, run_verify
    from postproc.command import post_text

    programs = _programs(args.chain)
    tools = [tool for _, _, tool in programs]
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {}
    for key in args.forms.split(","):
        post, suffix, extra = FORMS[key]
        start = time.perf_counter()
        files = []
        for name, apt, _ in programs:
            path = args.out / key / f"{name}.{suffix}"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(post_text(apt, args.machine, post=post, tcp=True,
                                      post_options=extra))
            files.append(path)
        posted = time.perf_counter() - start
        report_dir = args.out / key / "verify"
        run_verify(files, args.machine, tools, str(args.spec), args.spec, args.resolution,
                   report_dir, options=VerifyOptions(render=False), progress=False)
        report = json.loads((report_dir / "verify.json").read_text())
        results[key] = {
            "post_s": round(posted, 1),
            "verify_s": round(time.perf_counter() - start - posted, 1),
            "volumes_mm3": [p["removed_volume_mm3"] for p in report["programs"]],
            "events": dict(Counter(e["type"] for e in report["events"])),
            "block_events": _block_events(files, report, args.machine),
        }
        print(key, json.dumps({k: v for k, v in results[key].items()
                               if k != "block_events"}), flush=True)
    compare(results)
    summary = {"chain": str(args.chain), "machine": str(args.machine),
               "resolution_mm": args.resolution,
               "programs": [name for name, _, _ in programs], "forms": results}
    (args.out / "cross_dialect.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
