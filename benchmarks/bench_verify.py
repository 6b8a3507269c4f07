"""Benchmark: the tri-dexel engine against today's engine (commit 7e9ac6f), one run.

Same moves, same tool (6 mm ball, 12 mm flutes), same stock, side by side:

* **3-axis**: six parallel slots (plunge + 12 collinear 2 mm feed moves + retract
  each) into a 60 x 44 x 15 mm box, 89 moves; the removed volume has a closed form
  (``tests/cam/test_verify_volume.py``).
* **5-axis**: 8 joint-mode blocks of the LinuxCNC ``xyzac-trt`` machine whose A and C
  turn inside each block, subdivided by ``cam.verify.motion`` within 0.01 mm: 914
  short sub-moves (0.047 mm on average) in a 36 x 28 x 10 mm box.

The moves are made once, in this process, and handed to every engine run through
one ``.npz`` file, so old and new sweep exactly the same moves. Each engine and
resolution runs in a fresh subprocess (the old one with ``PYTHONPATH`` set to a
checkout of 7e9ac6f, ``--old``, default ``/work/wt/base``); CPU seconds are the
child's own (``time.process_time``, all threads), wall seconds its elapsed time. The
new engine runs with one thread and with two (one grid per thread): its results are
the same, only the wall time differs.

``--thirdparty`` adds LinuxCNC's 7-blade impeller demo (``run_verify`` end to end
without renders, 0.1 mm): CPU and wall seconds, sub-moves, removed volume and the
events of each engine. The old engine needs about 340 s of CPU there.

``--base PATH`` adds a second baseline (any checkout, e.g. the current main in a
temporary worktree) beside the old engine, one thread; ``--no-old-demo`` leaves the old
engine out of the demo.

Run: ``python benchmarks/bench_verify.py [--thirdparty] [--old PATH] [--base PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

R = 3.0
FLUTE = 12.0
BOXES = {
    "3axis": (np.array([-30.0, -22.0, -15.0]), np.array([30.0, 22.0, 0.0])),
    "5axis": (np.array([-18.0, -14.0, -10.0]), np.array([18.0, 14.0, 0.0])),
}
DEMO = Path(
    "/usr/share/doc/linuxcnc/examples/sample-configs/sim/axis/vismach/5axis/"
    "table-rotary-tilting/demos/impeller-7bl-xyzac.ngc"
)


def three_axis_moves() -> tuple[np.ndarray, np.ndarray, float]:
    """Polyline of tips (n, 3) for six slots and the closed-form removed volume."""
    e = 1.0
    tip_z = -e - R
    length, pts = 24.0, []
    rows = np.arange(-17.5, 17.6, 7.0)  # six slots, 1 mm of stock between neighbours
    for y in rows:
        pts.append((-12.0, y, 5.0))
        pts += [(-12.0 + 2.0 * i, y, tip_z) for i in range(13)]
        pts.append((12.0, y, 5.0))
    tips = np.array(pts)
    n_slots = len(rows)
    section = 0.5 * math.pi * R * R + 2.0 * R * e
    ends = 2.0 * (math.pi * R**3 / 3.0 + 0.5 * math.pi * R * R * e)
    return tips, np.tile([0.0, 0.0, 1.0], (len(tips), 1)), n_slots * (length * section + ends)


def five_axis_moves() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-moves (tips, displacements, axes) of 8 turning blocks on xyzac-trt."""
    from cam.verify.motion import program_moves
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine
    from postproc.program import MachineProgram

    machine = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")
    kins = kinematics_for(machine)
    n = 8
    t = np.linspace(0.0, 1.0, n)
    joints = np.column_stack([
        -10.0 + 20.0 * t, 5.0 * np.sin(4 * t), -3.0 + 1.0 * np.cos(3 * t),
        np.radians(-12.0 - 6.0 * np.sin(5 * t)), np.radians(24.0 * t),
    ])
    program = MachineProgram(
        joints=joints, motion=np.ones(n, np.int8), feed_mode=np.full(n, 94, np.int16),
        feed=np.full(n, 500.0), line=np.arange(1, n + 1), tcp=np.zeros(n, bool),
        tool_number=np.ones(n, np.int32), start=np.r_[-12.0, 0.0, 6.0, 0.0, 0.0],
    )
    moves = program_moves(program, machine, kins, math.hypot(FLUTE, R), 0.01,
                          start_at_first=False)
    return moves.tips, moves.moves, moves.axes


def _tool():  # type: ignore[no-untyped-def]
    from cam.tools import Tool

    return Tool(name="ball6", number=1, shape="ball", diameter=2 * R, corner_radius=R,
                flute_length=FLUTE, shank_diameter=2 * R, stickout=FLUTE)


# ---------------------------------------------------------------------- children
def run_sweep(case: str, pitch: float, moves_file: str, threads: int) -> dict:
    """Sweep the saved moves of ``case`` with whichever ``cam`` is on the path."""
    from cam.verify.stock import Stock
    from cam.verify.toolshape import tool_shape

    data = np.load(moves_file)
    tips, moves, axes = data[f"{case}_tips"], data[f"{case}_moves"], data[f"{case}_axes"]
    shape = tool_shape(_tool())
    warm = Stock.box([-1, -1, -1], [1, 1, 0], 0.5)
    warm.sweep(tips[:2] * 0, moves[:2] * 0, axes[:2], np.zeros(2, np.int32), shape)
    # the same sweep on a fresh stock until 1.5 s of CPU (at most 10 runs, at least
    # one): the fastest run counts (the machine is shared, interference only adds)
    runs: list[tuple[float, float]] = []
    while not runs or (sum(r[1] for r in runs) < 1.5 and len(runs) < 10):
        stock = Stock.box(BOXES[case][0], BOXES[case][1], pitch)
        if threads:
            stock.threads = threads
        before = stock.volume()
        wall, cpu = time.perf_counter(), time.process_time()
        stats = stock.sweep(tips, moves, axes, np.arange(len(tips), dtype=np.int32), shape)
        runs.append((time.perf_counter() - wall, time.process_time() - cpu))
    wall, cpu = min(r[0] for r in runs), min(r[1] for r in runs)
    counters = [int(sum(g.counters[i] for g in stock.grids)) for i in range(6)] if hasattr(
        stock.grids[0], "counters") else None
    return {"removed": before - stock.volume(), "wall": wall, "cpu": cpu, "moves": len(tips),
            "runs": len(runs),
            "cut": float(stats[:, 0].sum()), "longest": float(stats[:, 1].max()),
            # what the events are made of: moves cutting deeper than the contact
            # tolerance along a ray (rapid_in_stock if a rapid), body contact deeper
            "cutting": np.flatnonzero(stats[:, 1] > 0.01).tolist(),
            "contact": np.flatnonzero(stats[:, 2] > 0.01).tolist(),
            "counters": counters,
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def run_demo(pitch: float) -> dict:
    """LinuxCNC's impeller demo through ``run_verify`` (no renders)."""
    import cam
    from cam.verify.command import VerifyOptions, run_verify

    # the fixtures of the engine's own checkout: 7e9ac6f cannot read today's machine
    # file (its [model] table came later); tool and blank are the same files
    home = Path(cam.__file__).resolve().parents[1] / "fixtures"
    third = home / "nc" / "thirdparty"
    out = Path(tempfile.mkdtemp()) / "out"
    wall, cpu = time.perf_counter(), time.process_time()
    run_verify([DEMO], home / "machines" / "xyzac-trt.toml",
               f"{third / 'tools.toml'}:ball4_long", str(third / "impeller-7bl-blank.stl"),
               None, pitch, out, options=VerifyOptions(render=False), progress=False)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    data = json.loads((out / "verify.json").read_text())
    events = sorted((e["type"], e["line"], round(e["amount"], 4)) for e in data["events"])
    return {"wall": wall, "cpu": cpu, "moves": data["programs"][0]["sub_moves"],
            "removed": data["removed_volume_mm3"], "counts": data["event_counts"],
            "events": events,
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _child(engine: str, checkout: Path, *args: str) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(checkout)
    out = subprocess.run(
        [sys.executable, __file__, "--one", engine, *args],
        check=True, capture_output=True, text=True, cwd=ROOT, env=env,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _row(name: str, res: dict, ref: float) -> str:
    err = 100 * (res["removed"] - ref) / ref
    return (f"{name:22s} {res['moves']:6d} {res['cpu']:8.3f} {res['wall']:8.3f} "
            f"{res['moves'] / res['cpu']:10.0f} {res['moves'] / res['wall']:10.0f} "
            f"{res['removed']:12.4f} {err:+9.5f} {res['memory_mb']:7.0f} {res.get('runs', 1):4d}")


def main(old: Path, thirdparty: bool, base: Path | None = None, old_demo: bool = True) -> None:
    sys.path.insert(0, str(ROOT))
    pts, axes3, exact3 = three_axis_moves()
    tips5, moves5, axes5 = five_axis_moves()
    moves_file = Path(tempfile.mkdtemp()) / "moves.npz"
    np.savez(moves_file, **{
        "3axis_tips": pts[:-1], "3axis_moves": np.diff(pts, axis=0), "3axis_axes": axes3[:-1],
        "5axis_tips": tips5, "5axis_moves": moves5, "5axis_axes": axes5,
    })
    print(f"old engine: {old} (7e9ac6f); new engine: {ROOT}"
          + ("" if base is None else f"; base engine: {base}"))
    print(f"{'case':22s} {'moves':>6s} {'cpu s':>8s} {'wall s':>8s} {'moves/cpu s':>10s} "
          f"{'moves/wall s':>10s} {'removed mm3':>12s} {'vs old %':>9s} {'peak MB':>7s} runs")
    for case in ("3axis", "5axis"):
        for pitch in (0.1, 0.05):
            args = (case, str(pitch), str(moves_file))
            before = _child("old", old, *args, "0")
            prior = None if base is None else _child("base", base, *args, "1")
            one = _child("new", ROOT, *args, "1")
            two = _child("new", ROOT, *args, "2")
            ref = before["removed"]
            print(_row(f"{case} {pitch} old", before, ref))
            if prior is not None:
                print(_row(f"{case} {pitch} base 1 thread", prior, ref))
            print(_row(f"{case} {pitch} new 1 thread", one, ref))
            print(_row(f"{case} {pitch} new 2 threads", two, ref))
            print(f"  -> {before['cpu'] / one['cpu']:.1f}x moves per CPU s (1 thread), "
                  f"{before['cpu'] / two['cpu']:.1f}x (2 threads), "
                  f"{before['wall'] / two['wall']:.1f}x per wall s (2 threads); "
                  f"volume {'identical' if one['removed'] == two['removed'] else 'DIFFERS'}"
                  f" for 1 and 2 threads", flush=True)
            if prior is not None:
                agree = (prior["removed"] == one["removed"] and prior["cutting"] == one["cutting"]
                         and prior["contact"] == one["contact"])
                print(f"     against the base (1 thread): {prior['cpu'] / one['cpu']:.2f}x CPU; "
                      f"removed volume and event moves {'identical' if agree else 'DIFFER'}")
            same = all(r["cutting"] == before["cutting"] and r["contact"] == before["contact"]
                       for r in (one, two))
            print(f"     moves cutting > 0.01 mm along a ray: {len(before['cutting'])} (old), "
                  f"body contact: {len(before['contact'])}; event moves "
                  f"{'the same' if same else 'DIFFER'} (old, new 1 and 2 threads)")
            per = [c / one["moves"] for c in one["counters"]]
            print(f"     per move (new): {per[0]:.0f} rays in the footprint, {per[1]:.0f} whose "
                  f"material meets the capsule, {per[3]:.0f} closed-form and {per[4]:.0f} "
                  f"general intervals, {per[5]:.0f} rays changed; "
                  f"{1e9 * one['cpu'] / one['counters'][0]:.1f} ns CPU per footprint ray, "
                  f"{1e9 * one['cpu'] / one['counters'][5]:.0f} ns per changed ray", flush=True)
        if case == "3axis":
            print(f"  closed form 3-axis volume {exact3:.4f} mm3")
    if thirdparty:
        print("\nLinuxCNC impeller-7bl-xyzac.ngc, 0.1 mm, run_verify without renders")
        results = {}
        engines = {"new": ROOT, **({} if base is None else {"base": base}),
                   **({"old": old} if old_demo else {})}
        for engine, checkout in engines.items():
            res = _child(engine, checkout, "demo", "0.1", "-", "0")
            results[engine] = res
            print(f"  {engine}: {res['moves']} sub-moves, {res['cpu']:.1f} s CPU, "
                  f"{res['wall']:.1f} s wall, removed {res['removed']:.3f} mm3, "
                  f"peak {res['memory_mb']:.0f} MB, events {res['counts']}", flush=True)
        for engine in results:
            if engine == "new":
                continue
            same = [tuple(e[:2]) for e in results["new"]["events"]] == [
                tuple(e[:2]) for e in results[engine]["events"]]
            print(f"  events (type, line) {'the same' if same else 'DIFFER'}; "
                  f"{engine} {results[engine]['events']}; new {results['new']['events']}")
            print(f"  -> against {engine}: {results[engine]['cpu'] / results['new']['cpu']:.2f}x "
                  f"CPU, {results[engine]['wall'] / results['new']['wall']:.2f}x wall")


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "--one":
        engine, case, pitch, moves_file, threads = sys.argv[2:7]
        if case == "demo":
            print(json.dumps(run_demo(float(pitch))))
        else:
            print(json.dumps(run_sweep(case, float(pitch), moves_file, int(threads))))
    else:
        parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
        parser.add_argument("--thirdparty", action="store_true",
                            help="also LinuxCNC's impeller demo at 0.1 mm (old: ~340 s CPU)")
        parser.add_argument("--old", type=Path, default=Path("/work/wt/base"),
                            help="checkout of today's engine (commit 7e9ac6f)")
        parser.add_argument("--base", type=Path, default=None,
                            help="a second baseline checkout (e.g. main), 1 thread")
        parser.add_argument("--no-old-demo", action="store_true",
                            help="skip the old engine on the demo (~340 s of CPU)")
        ns = parser.parse_args()
        main(ns.old, ns.thirdparty, ns.base, not ns.no_old_demo)
