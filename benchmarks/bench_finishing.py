"""Benchmark: the main job's finish stage, a baseline commit against this tree.

In one invocation, on nine_blade at the main job's settings (the spec's
``[machining]`` table, machine trunnion-500, and what ``cam/run/stages.py``
``finish_options`` adds: ``clearance_mm`` = 0.5 + the roughed stock,
``clearance_exact_mm`` at least that), it runs ``run_finish``

1. with the baseline code (``--baseline-path DIR``, a checkout of the baseline, or
   ``--baseline-ref REF``, checked out into a temporary git worktree; default
   7e9ac6f) in a child process, and
2. with this tree's code in a second child process,

and prints per side the finish stage's wall and CPU time (the child's process
time and that of the processes it forked: robust to a shared machine), points, cost
per point, A/C reversals and collisions, then the ratios and whether the APT files
are byte-identical.
Independently of the planner's scene, every APT pose of this tree's programs is
then re-checked with python-fcl against the geometry stage's STL
(``Impeller.export_stl``, read back from the file): the cutter shrunk by the
cutter allowance and shank/holder may not touch it, and shank/holder keep
``clearance_mm`` (one collide of shank/holder grown by ``clearance_mm``; an
``fcl.distance`` where that touches). Motions between poses are not re-checked.

Each child gets its own numba cache folder (``--cache DIR``, kept between
invocations): the first invocation includes compilation on both sides, later ones
are warm.

``--production`` runs this tree alone at production tolerances (the main job's
settings with scallop ``PRODUCTION["scallop_mm"]`` = 0.01 mm and chordal tolerance
``PRODUCTION["chordal_tolerance_mm"]`` = 0.01 mm, the spec's point spacing as the
cap; all nine passages unless ``--passages``): the baseline has no chordal
tolerance, so there is nothing to compare with; the re-check runs as above. Run:

    .venv/bin/python benchmarks/bench_finishing.py [--baseline-path /work/wt/base]
        [--passages N] [--keep DIR] [--skip-baseline] [--production] [--no-recheck]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml"
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
APT = ("finish_junction.apt", "finish_blade.apt", "finish_hub.apt")
#: ``FinishOptions().clearance_mm`` and ``clearance_exact_mm`` defaults (as of 7e9ac6f).
DEFAULT_CLEARANCE, DEFAULT_EXACT = 0.5, 3.0
#: What ``--production`` sets over the main job's finishing options (mm).
PRODUCTION = {"scallop_mm": 0.01, "chordal_tolerance_mm": 0.01}


def main_job_settings(spec: Path) -> tuple[str, dict[str, Any]]:
    """Finishing tool and options of the main job (``stages.finish_options``)."""
    with open(spec, "rb") as handle:
        doc = tomllib.load(handle)
    machining = doc["machining"]
    options: dict[str, Any] = dict(machining.get("finish", {}))
    allowance = doc["allowances"]
    rough = float(allowance["finishing_mm"]) + float(machining["rough"]["scallop_mm"])
    stock = max(rough, float(allowance["stock_mm"]))
    options["clearance_mm"] = float(options.get("clearance_mm", DEFAULT_CLEARANCE)) + stock
    options["clearance_exact_mm"] = max(float(options.get("clearance_exact_mm", DEFAULT_EXACT)),
                                        options["clearance_mm"])
    return str(machining["finish_tool"]), options


def _cpu() -> float:
    """CPU seconds of this process and of the processes it forked and waited for (the
    planner's pass groups, ``impeller_cam.processes``)."""
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def edge_child(spec: Path, machine: Path, tool_name: str, options: dict[str, Any]) -> None:
    """Plan the edge passes alone (``plan_edges`` of whichever module the tree has) and
    print a JSON line: CPU and wall of the planning only (the scene is built first)."""
    import numpy as np

    from cam.collision import CollisionScene
    from cam.finishing.options import FinishOptions
    from cam.finishing.scene import solid_meshes
    from cam.tools import resolve_tool
    from geometry.impeller import Impeller
    from geometry.spec import load_spec
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    try:
        from cam.finishing.edge_plan import plan_edges
    except ImportError:  # the trees before the edge operation had its own module
        from cam.finishing.fillet_plan import plan_edges
    opts = FinishOptions.from_mapping(options)
    tool = resolve_tool(tool_name)
    kins = kinematics_for(load_machine(machine))
    impeller = Impeller(load_spec(spec))
    scene = CollisionScene(solid_meshes(impeller, opts.tessellation_mm))
    wall, cpu = time.perf_counter(), time.process_time()
    result = plan_edges(impeller.surfaces, tool, kins, scene, opts, scene_source="solid")
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    lean = [np.degrees(np.arcsin(np.clip(np.einsum("ij,ij->i", p.axis, p.path.normal), -1, 1)))
            for p in result.paths]
    print(json.dumps({
        "wall": wall, "cpu": cpu, "points": int(sum(len(p.path) for p in result.paths)),
        "paths": len(result.paths),
        "edges": sorted({p.path.name.split(".")[3] for p in result.paths}),
        "collisions": int(sum(p.interference.interfering_points.size for p in result.paths)),
        "remedied": int(sum(p.interference.delta_c != 0 for p in result.paths)),
        "repaired": int(sum(p.repair is not None for p in result.paths)),
        "min_lean_deg": round(float(min(x.min() for x in lean)), 3),
        "leaning_in": int(sum(int((x < 0).sum()) for x in lean))}))


def child(out: Path, tool: str, options: dict[str, Any]) -> None:
    """Run the finish stage with whatever ``cam`` the path gives; print a JSON line."""
    import cam
    from cam.finishing.command import run_finish

    # each side reads its own tree's fixtures: a newer machine file may carry tables
    # (e.g. [model]) that the older code refuses
    tree = Path(cam.__file__).resolve().parents[1]
    spec, machine = (tree / p.relative_to(ROOT) for p in (SPEC, MACHINE))
    from dataclasses import fields

    from cam.finishing.options import FinishOptions

    if "edge_passes" not in {f.name for f in fields(FinishOptions)}:
        options.pop("edge_passes", None)  # a tree before the edge passes (7e9ac6f)
    if options.pop("edge_only", False):
        edge_child(spec, machine, tool, options)
        return
    commit = tree_commit(tree)
    wall, cpu = time.perf_counter(), _cpu()
    doc = run_finish(spec, machine, tool, out, progress=False, plots=False, **options)
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    s = doc["summary"]
    print(json.dumps({"wall": wall, "cpu": cpu, "points": s["points"], "paths": s["paths"],
                      "reversals_after": s["reversals_after"], "collisions": s["collisions"],
                      "motion_collisions": s["motion_collisions"],
                      "link_collisions": doc["link_collisions"],
                      "min_clearance_mm": s["min_clearance_mm"],
                      "cam": __import__("cam").__file__, "commit": commit}))


def tree_commit(tree: Path) -> str:
    """The commit checked out at ``tree`` (``+dirty`` with uncommitted changes to
    tracked files), read when the child starts planning: the code it runs."""
    def git(*args: str) -> str:
        done = subprocess.run(["git", "-C", str(tree), *args], capture_output=True,
                              text=True, check=False)
        return done.stdout.strip()

    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    return (git("rev-parse", "--short", "HEAD") or "unknown") + ("+dirty" if dirty else "")


def run_side(code: Path, out: Path, cache: Path, tool: str, options: dict[str, Any],
             passages: int | None) -> dict[str, Any]:
    """One child process on the code at ``code``; its JSON answer."""
    if passages is not None:
        options = dict(options, passages=passages)
    env = dict(os.environ, PYTHONPATH=str(code), NUMBA_CACHE_DIR=str(cache),
               PYTHONDONTWRITEBYTECODE="1")
    command = [sys.executable, str(Path(__file__).resolve()), "--child", str(out), "--tool",
               tool, "--options", json.dumps(options)]
    done = subprocess.run(command, env=env, cwd=code, capture_output=True, text=True,
                          check=False)
    if done.returncode:
        raise SystemExit(f"child on {code} failed:\n{done.stderr[-4000:]}")
    answer: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return answer


def recheck(folder: Path, stl: Path, tool_name: str, options: dict[str, Any]
            ) -> dict[str, Any]:
    """Every APT pose of ``folder`` against the STL with python-fcl (see module doc)."""
    import fcl
    import numpy as np
    import trimesh

    from cam.collision.postures import rotations_to
    from cam.collision.tool_mesh import (
        bvh_model,
        concatenate,
        grown_profile,
        revolve,
        tool_geometry,
    )
    from cam.tools import resolve_tool
    from postproc.apt import read_apt

    mesh = trimesh.load(stl, force="mesh")
    part = fcl.CollisionObject(bvh_model(np.asarray(mesh.vertices), np.asarray(mesh.faces)))
    tool = resolve_tool(tool_name)
    allowance = float(options.get("cutter_allowance_mm", 0.05))
    limit = float(options["clearance_mm"])
    parts = tool_geometry(tool, cutter_offset=-allowance)
    cutter = fcl.CollisionObject(parts["cutter"].bvh)
    body_parts = [parts[n] for n in ("shank", "holder") if n in parts]
    body_mesh = concatenate([p.mesh for p in body_parts])
    body = fcl.CollisionObject(bvh_model(body_mesh.vertices, body_mesh.faces))
    grown_mesh = concatenate([revolve(grown_profile(p.profile, limit), 48) for p in body_parts])
    grown = fcl.CollisionObject(bvh_model(grown_mesh.vertices, grown_mesh.faces))
    poses = contacts = close = distances = 0
    smallest = math.inf
    request, dist_request = fcl.CollisionRequest(), fcl.DistanceRequest()
    for name in APT:
        for path in read_apt(folder / name):
            rot = rotations_to(path.axis)
            for i in range(len(path.tip)):
                transform = fcl.Transform(rot[i], path.tip[i])
                poses += 1
                for obj in (cutter, body):
                    obj.setTransform(transform)
                    if fcl.collide(obj, part, request, fcl.CollisionResult()):
                        contacts += 1
                        break
                grown.setTransform(transform)
                if fcl.collide(grown, part, request, fcl.CollisionResult()):
                    distances += 1
                    d = fcl.distance(body, part, dist_request, fcl.DistanceResult())
                    smallest = min(smallest, d)
                    close += int(d < limit)
    return {"poses": poses, "contacts": contacts, "below_clearance": close,
            "distance_calls": distances,
            "smallest_checked_mm": None if math.isinf(smallest) else round(smallest, 4)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-path", type=Path, default=None,
                        help="checkout of the baseline code")
    parser.add_argument("--baseline-ref", default="7e9ac6f",
                        help="git ref checked out into a temporary worktree (default)")
    parser.add_argument("--skip-baseline", action="store_true")
    parser.add_argument("--passages", type=int, default=None, help="passages (default all)")
    parser.add_argument("--keep", type=Path, default=None, help="keep the outputs here")
    parser.add_argument("--production", action="store_true",
                        help="this tree alone at production tolerances (PRODUCTION)")
    parser.add_argument("--no-recheck", action="store_true",
                        help="skip the python-fcl re-check of the new APT poses")
    parser.add_argument("--cache", type=Path,
                        default=Path(tempfile.gettempdir()) / "impeller-cam-bench-numba")
    parser.add_argument("--child", type=Path, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--tool", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--options", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--edge-only", action="store_true",
                        help="time the edge passes' planning alone on both sides (scene "
                             "built first, not timed; no APT, no re-check)")
    parser.add_argument("--edge-passes", action="store_true",
                        help="plan the edge passes (issue 28) on both sides (a baseline "
                             "without them, 7e9ac6f, plans none): off, both do the same work")
    args = parser.parse_args()
    if args.child is not None:
        child(args.child, args.tool, json.loads(args.options))
        return
    tool, options = main_job_settings(SPEC)
    if args.edge_only:
        edge_bench(args, tool, options)
        return
    if args.production:
        options.update(PRODUCTION)
        args.skip_baseline = True
    print(f"nine_blade, {tool}, {MACHINE.name}, options {options}, "
          f"passages {args.passages or 'all'}")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        sides: dict[str, dict[str, Any]] = {}
        worktree = None
        if not args.skip_baseline:
            base = args.baseline_path
            if base is None:
                worktree = Path(tmp) / "baseline"
                subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach",
                                str(worktree), args.baseline_ref], check=True,
                               capture_output=True)
                base = worktree
            try:
                sides["baseline"] = run_side(base.resolve(), work / "baseline",
                                             args.cache / "baseline", tool,
                                             dict(options, edge_passes=args.edge_passes),
                                             args.passages)
            finally:
                if worktree is not None:
                    subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                    str(worktree)], check=False, capture_output=True)
        sides["new"] = run_side(ROOT, work / "new", args.cache / "new", tool,
                                dict(options, edge_passes=args.edge_passes), args.passages)
        print(f"{'side':<9} {'wall s':>8} {'cpu s':>8} {'points':>7} {'ms/pt wall':>10} "
              f"{'ms/pt cpu':>9} {'pt/s cpu':>8} {'A/C rev':>7} {'coll':>5} {'motion':>6} "
              f"{'links':>5} {'min clear':>9}")
        for name, s in sides.items():
            rev = f"{s['reversals_after']['A']}/{s['reversals_after']['C']}"
            print(f"{name:<9} {s['wall']:>8.1f} {s['cpu']:>8.1f} {s['points']:>7} "
                  f"{1e3 * s['wall'] / s['points']:>10.2f} {1e3 * s['cpu'] / s['points']:>9.2f} "
                  f"{s['points'] / s['cpu']:>8.0f} {rev:>7} {s['collisions']:>5} "
                  f"{s['motion_collisions']:>6} {s['link_collisions']:>5} "
                  f"{s['min_clearance_mm']!s:>9}")
        print("code:", ", ".join(f"{name} {s.get('commit', '?')}" for name, s in sides.items()))
        if "baseline" in sides:
            old, new = sides["baseline"], sides["new"]
            print(f"speed-up: wall {old['wall'] / new['wall']:.1f}x, "
                  f"cpu {old['cpu'] / new['cpu']:.1f}x")
            same = [(work / "baseline" / a).read_bytes() == (work / "new" / a).read_bytes()
                    for a in APT]
            print("APT byte-identical to the baseline:", dict(zip(APT, same, strict=True)))
        if args.no_recheck:
            return
        from geometry.impeller import Impeller
        from geometry.spec import load_spec

        stl = Impeller(load_spec(SPEC)).export_stl(work / "impeller.stl")
        start = time.perf_counter()
        check = recheck(work / "new", stl, tool, options)
        print(f"re-check of the new APT poses against {stl.name} (python-fcl, "
              f"{time.perf_counter() - start:.0f} s): {check}")


def edge_bench(args: argparse.Namespace, tool: str, options: dict[str, Any]) -> None:
    """``--edge-only``: the edge passes' planning on the baseline and this tree, one run."""
    if args.baseline_path is None:
        raise SystemExit("--edge-only needs --baseline-path")
    print(f"nine_blade edge passes, {tool}, {MACHINE.name}, options {options}, "
          f"passages {args.passages or 'all'}")
    options = dict(options, edge_only=True)
    sides = {name: run_side(code.resolve(), Path(tempfile.gettempdir()), args.cache / name,
                            tool, options, args.passages)
             for name, code in (("baseline", args.baseline_path), ("new", ROOT))}
    print(f"{'side':<9} {'cpu s':>7} {'wall s':>7} {'paths':>5} {'points':>6} "
          f"{'us/pt cpu':>9} {'remedied':>8} {'repaired':>8} {'min lean':>8} "
          f"{'lean in':>7}  edges")
    for name, s in sides.items():
        print(f"{name:<9} {s['cpu']:>7.1f} {s['wall']:>7.1f} {s['paths']:>5} {s['points']:>6} "
              f"{1e6 * s['cpu'] / s['points']:>9.0f} {s['remedied']:>8} {s['repaired']:>8} "
              f"{s['min_lean_deg']:>8.2f} {s['leaning_in']:>7}  {','.join(s['edges'])}")
    old, new = sides["baseline"], sides["new"]
    print(f"per point: {old['cpu'] / old['points'] / (new['cpu'] / new['points']):.1f}x less CPU")


if __name__ == "__main__":
    main()
