"""The chain's verify stage, sub-part by sub-part, for one or two checkouts in one run.

The verify stage (``cam.run.verification.verify_chain``) of a chain output folder whose
``post`` stage is done runs in a child process per checkout (``PYTHONPATH`` and the
working directory set to it), each into its own folder (symbolic links to the
folder's ``geometry``, ``rough``, ``finish`` and ``nc``, and a copy of the finish
stage's ``verify/rough``, which the stage reuses as in the main job), so the old code
and the new see the same NC programs. In the child, named functions are wrapped with timers
(wall and process CPU seconds, all threads; a function the checkout does not have is
skipped), per verification run (``rough``, ``finish``) where they run inside one:

* ``sweep``: ``Stock.sweep`` (the dexel kernels, with their per-batch set-up);
* ``moves``: ``cam.verify.motion.program_moves`` (NC blocks to sub-moves); ``read_nc``;
* ``blank``: the initial stock (``load_stock``: the blank cast, or a saved state read);
* ``save`` / ``load``: ``Stock.save`` / ``Stock.load``;
* ``samples``: ``Stock.surface_samples``; ``distance``: ``DesignDistance.closest``;
* ``events``: ``_deviation_events``; ``renders``: ``_render_stock``,
  ``_render_deviation`` (and ``_stock_surface``, ``_surface_deviation`` where the
  checkout has them); ``outputs``: ``_write_outputs`` (the save included);
* ``design``: ``LabelledDesign`` (the solid, its mesh, the signed distance);
* ``regions``: ``region_summary``, and inside it ``near_faces``, ``passage_position``,
  ``shroud_offset``, ``on_tip_edge``.

Times are inclusive (``outputs`` holds ``save``). Run:
``python benchmarks/bench_verify_stage.py OUT/nine_blade [--old PATH] [--new PATH]
[--resolution MM] [--work DIR]``; prints a table, writes ``WORK/bench_verify_stage.json``.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: (label, module, attribute path) of the timed functions.
TARGETS = (
    ("sweep", "cam.verify.stock", "Stock.sweep"),
    ("moves", "cam.verify.motion", "program_moves"),
    ("read_nc", "postproc.nc_reader", "read_nc"),
    ("blank", "cam.verify.sources", "load_stock"),
    ("save", "cam.verify.stock", "Stock.save"),
    ("load", "cam.verify.stock", "Stock.load"),
    ("samples", "cam.verify.stock", "Stock.surface_samples"),
    ("distance", "cam.verify.deviation", "DesignDistance.closest"),
    ("events", "cam.verify.command", "_deviation_events"),
    ("renders", "cam.verify.command", "_render_stock"),
    ("renders", "cam.verify.command", "_render_deviation"),
    ("renders", "cam.verify.command", "_stock_surface"),
    ("renders", "cam.verify.command", "_surface_deviation"),
    ("outputs", "cam.verify.command", "_write_outputs"),
    ("design", "cam.run.regions", "LabelledDesign.__init__"),
    ("regions", "cam.run.regions", "region_summary"),
    ("near_faces", "cam.run.regions", "near_faces"),
    ("passage_position", "cam.run.regions", "passage_position"),
    ("shroud_offset", "cam.run.regions", "shroud_offset"),
    ("on_tip_edge", "cam.run.regions", "on_tip_edge"),
)
#: Chain folders the verify stage reads.
INPUTS = ("geometry", "rough", "finish", "nc", "run.json")


def _install_timers(times: dict[str, dict[str, float]], phase: list[str]) -> None:
    """Wrap every target found (and each module's imported copy of it) with a timer."""
    import importlib

    def timed(label: str, func: Any) -> Any:
        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            wall, cpu = time.perf_counter(), time.process_time()
            try:
                return func(*args, **kwargs)
            finally:
                key = f"{phase[0]}:{label}"
                entry = times.setdefault(key, {"wall_s": 0.0, "cpu_s": 0.0, "calls": 0})
                entry["wall_s"] += time.perf_counter() - wall
                entry["cpu_s"] += time.process_time() - cpu
                entry["calls"] += 1
        return wrapper

    for module_name in ("cam.run.verification", "cam.verify.command"):
        importlib.import_module(module_name)
    for label, module_name, path in TARGETS:
        try:
            owner: Any = importlib.import_module(module_name)
        except ImportError:
            continue
        *parents, name = path.split(".")
        for part in parents:
            owner = getattr(owner, part, None)
        func = getattr(owner, name, None) if owner is not None else None
        if func is None:
            continue
        wrapped = timed(label, func)
        setattr(owner, name, wrapped)
        if not parents:  # `from module import func` copies elsewhere
            for module in list(sys.modules.values()):
                if module is not None and getattr(module, name, None) is func:
                    setattr(module, name, wrapped)


def child(out: Path, resolution: float | None) -> dict[str, Any]:
    """Run the verify stage on ``out`` with timers; the timings and the stage's results."""
    from cam.run.chain import run_chain

    times: dict[str, dict[str, float]] = {}
    phase = ["stage"]
    _install_timers(times, phase)
    import cam.verify.command as command

    run_verify = command.run_verify
    runs = iter(("rough", "finish"))

    @functools.wraps(run_verify)
    def phased(*args: Any, **kwargs: Any) -> Any:
        phase[0] = next(runs, "extra")
        try:
            return run_verify(*args, **kwargs)
        finally:
            phase[0] = "stage"

    command.run_verify = phased  # type: ignore[assignment]
    record = json.loads((out / "run.json").read_text())
    settings = dict(record["settings"])
    if resolution is not None:
        settings["verify_resolution_mm"] = resolution
    keys = ("rough", "finish", "verify_resolution_mm", "tessellation_mm")
    wall, cpu = time.perf_counter(), time.process_time()
    run_chain(record["spec"], record["machine"], out, only="verify", progress=False,
              rough_tool=settings["rough_tool"], finish_tool=settings["finish_tool"],
              **{k: settings[k] for k in keys if k in settings})
    total = {"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}
    regions = json.loads((out / "verify" / "regions.json").read_text())
    results = {}
    for kind in ("rough", "finish"):
        data = json.loads((out / "verify" / kind / "verify.json").read_text())
        results[kind] = {"event_counts": data["event_counts"],
                         "deviation": data["deviation"],
                         "removed_volume_mm3": data["removed_volume_mm3"],
                         "accepted": regions[kind]["accepted"],
                         "acceptance_max_mm": {r: t.get("max_mm") for r, t in
                                               regions[kind]["acceptance"].items()}}
    return {"total": total, "times": times, "results": results}


def run_checkout(name: str, checkout: Path, source: Path, work: Path,
                 resolution: float | None) -> dict[str, Any]:
    """The verify stage of ``source`` with the code of ``checkout``, in a child process."""
    out = work / name
    out.mkdir(parents=True, exist_ok=True)
    for item in INPUTS:
        link = out / item
        if item == "run.json":
            link.write_text((source / item).read_text())
        elif not link.exists():
            link.symlink_to((source / item).resolve())
    # the finish stage's rough verification, which the stage reuses as the main job
    # does (a fresh copy: the stage replaces verify/ as a whole)
    if (source / "verify" / "rough" / "verify.json").is_file():
        shutil.rmtree(out / "verify", ignore_errors=True)
        shutil.copytree(source / "verify" / "rough", out / "verify" / "rough")
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    code = ("import json, sys; from pathlib import Path; "
            f"sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); "
            "import bench_verify_stage as b; "
            f"print('RESULT' + json.dumps(b.child(Path({str(out)!r}), {resolution!r})))")
    done = subprocess.run([sys.executable, "-c", code], cwd=checkout, env=env,
                          capture_output=True, text=True, check=False)
    lines = [x for x in done.stdout.splitlines() if x.startswith("RESULT")]
    if done.returncode or not lines:
        raise RuntimeError(f"{name}: exit {done.returncode}\n{done.stderr[-3000:]}")
    result: dict[str, Any] = json.loads(lines[-1][len("RESULT"):])
    return result


def table(results: dict[str, dict[str, Any]]) -> str:
    """Wall / CPU seconds per sub-part and checkout."""
    keys = sorted({k for r in results.values() for k in r["times"]})
    head = f"{'part':<28}" + "".join(f"{n + ' wall':>14}{n + ' cpu':>14}{'calls':>8}"
                                     for n in results)
    rows = [head]
    for key in keys:
        row = f"{key:<28}"
        for r in results.values():
            t = r["times"].get(key)
            row += (f"{t['wall_s']:>14.1f}{t['cpu_s']:>14.1f}{t['calls']:>8}" if t
                    else f"{'-':>14}{'-':>14}{'-':>8}")
        rows.append(row)
    rows.append(f"{'stage total':<28}" + "".join(
        f"{r['total']['wall_s']:>14.1f}{r['total']['cpu_s']:>14.1f}{'':>8}"
        for r in results.values()))
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path, help="chain output folder (post stage done)")
    parser.add_argument("--old", type=Path, help="checkout of the old code")
    parser.add_argument("--new", type=Path, default=ROOT, help="checkout of the new code")
    parser.add_argument("--resolution", type=float, help="verify resolution, mm")
    parser.add_argument("--work", type=Path, default=ROOT / "out" / "bench_verify_stage")
    args = parser.parse_args()
    checkouts = {"new": args.new} if args.old is None else {"old": args.old, "new": args.new}
    results = {}
    for name, checkout in checkouts.items():
        results[name] = run_checkout(name, checkout.resolve(), args.source.resolve(),
                                     args.work.resolve(), args.resolution)
        print(f"{name}: {results[name]['total']['wall_s']:.1f} s wall, "
              f"{results[name]['total']['cpu_s']:.1f} s CPU; "
              f"{json.dumps(results[name]['results'])}", flush=True)
        args.work.mkdir(parents=True, exist_ok=True)
        (args.work / "bench_verify_stage.json").write_text(json.dumps(results, indent=2))
    print(table(results))


if __name__ == "__main__":
    main()
