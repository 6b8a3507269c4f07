"""Benchmark: posture collision checks per second, CollisionScene vs a plain fcl loop.

Both sides use the same scene meshes, the same tool meshes and the same fcl
objects; the plain side is ``cam.collision.plain_fcl_check`` (every posture,
every part, every role through ``fcl.collide``, first contact stops the
posture), the other ``CollisionScene.check_postures`` (vectorised broad phase,
fcl only for undecided triples). Scene and tool set-up is timed separately and
not counted in either rate. Rates are from CPU time (best of ``--repeat``; both
sides are single-threaded, and the machine is shared), with the wall-clock
ratio alongside. The answers (collides, part, role) are compared
posture by posture; the number that differ must be 0.

Scene: the nine-blade impeller of ``fixtures/impellers/nine_blade/spec.toml``
through ``geometry.impeller`` when both exist, otherwise the synthetic
nine-blade impeller of ``cam.collision.synthetic`` (the script says which).

Postures: "hub contact": a ball 0.1 mm above a random hub surface point (the
cutter checked with a 0.05 mm allowance), axis tilted up to 30 deg from the hub
normal; "finishing-like": those of them whose ball is at least R + 0.5 mm from
blades and splitters (the ball in the passage, touching only the hub it cuts);
"approach": the tip lifted 0-20 mm along the normal; "random": tips uniform in
the bounding box, axes uniform on the upper half sphere. The last line compares
checks that also compute the shank+holder clearance (the exact GJK kernel,
docs/collision.md; fcl distance on the plain side).

``--finishing FIXTURE`` instead finishes a fixture (solid scene, trunnion-500, the
main job's settings: scallop 0.5 mm, spacing 1.5 mm, clearance 2.5 mm, exact up to
3 mm; all passages or ``--passages N``) and checks every posture of its finished
paths and every sub-sample of the motions between them both ways: hit/miss,
part and role compared posture by posture, clearances compared below the cap
(largest difference) and above it (the lower bound holds).

``--apt FOLDER`` checks the finishing a chain wrote (``impeller-cam run``'s
``finish/``, or ``impeller-cam finish``'s output): every posture of the cutting passes of every
operation's APT file (junction, blade, edge, hub, fillet; each with its own tool, as
finish.json names it) and every sub-sample of the motions between them, against the
design solid's scene of the spec finish.json names, with its options' clearance limit
and cap; the same comparison as ``--finishing``, per operation and in total. No
planning is repeated, so this covers the chain's fillet and edge passes too. Run:

    .venv/bin/python benchmarks/bench_collision.py [--postures N] [--seed S] [--synthetic | --dense]
    .venv/bin/python benchmarks/bench_collision.py --finishing nine_blade [--finish-tool T]
    .venv/bin/python benchmarks/bench_collision.py --apt OUT/finish
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from cam.collision import CollisionScene, PostureReport, plain_fcl_check
from cam.collision.synthetic import blade_mesh, hub_mesh, impeller_meshes
from cam.collision.tool_mesh import concatenate
from cam.tools import Tool, resolve_tool

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml"


def load_scene_meshes() -> tuple[dict[str, trimesh.Trimesh], str]:
    """Impeller meshes by role, and a line saying where they came from."""
    reason = f"{SPEC.relative_to(ROOT)} not found"
    if SPEC.is_file():
        try:
            from geometry.assembly import ROLES
            from geometry.impeller import Impeller

            impeller = Impeller.from_spec(SPEC)
            meshes = {}
            for role in ROLES:
                mesh = impeller.mesh(role=role)
                if len(mesh.faces):
                    meshes[role] = mesh
            if meshes:
                return meshes, f"geometry.impeller from {SPEC.relative_to(ROOT)}"
            reason = "geometry.impeller returned no meshes"
        except Exception as error:  # noqa: BLE001 - any failure: say so, use the fallback
            reason = f"geometry.impeller failed: {str(error)[:160]}"
    return impeller_meshes(9), f"synthetic nine-blade impeller (cam.collision.synthetic); {reason}"


def dense_meshes() -> tuple[dict[str, trimesh.Trimesh], str]:
    """The synthetic hub and nine blades tessellated finely (about 512k triangles)."""
    pitch = 2.0 * math.pi / 9
    blades = [blade_mesh(k * pitch, nu=150, nv=40) for k in range(9)]
    meshes = {"hub": hub_mesh(sections=720, samples=200), "blades": concatenate(blades)}
    return meshes, "synthetic nine-blade impeller, dense tessellation (--dense)"


def hub_postures(
    hub: trimesh.Trimesh, radius: float, n: int, rng: np.random.Generator, lift: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ball postures over random hub points: contact + 0.1 mm, tilt <= 30 deg."""
    area = hub.area_faces / hub.area_faces.sum()
    face = rng.choice(len(hub.faces), size=n, p=area)
    a, b = rng.random((2, n))
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    tri = hub.triangles[face]
    point = tri[:, 0] + a[:, None] * (tri[:, 1] - tri[:, 0]) + b[:, None] * (tri[:, 2] - tri[:, 0])
    normal = hub.face_normals[face]
    keep = normal[:, 2] > 0.05  # the passage side of the hub, not its back face or rim
    point, normal = point[keep], normal[keep]
    tilt = np.radians(30.0) * np.sqrt(rng.random(len(point)))
    helper = np.where(np.abs(normal[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal, e1)
    turn = rng.uniform(0, 2 * math.pi, len(point))
    axis = np.cos(tilt)[:, None] * normal + np.sin(tilt)[:, None] * (
        np.cos(turn)[:, None] * e1 + np.sin(turn)[:, None] * e2
    )
    centre = point + (radius + 0.1) * normal + rng.uniform(0, lift, len(point))[:, None] * normal
    return centre - radius * axis, axis


def in_passage(scene: CollisionScene, centre: np.ndarray, distance: float) -> np.ndarray:
    """``(n,) bool``: ball centres at least ``distance`` from every role but the hub."""
    keep = np.ones(len(centre), dtype=bool)
    for role in scene.roles:
        if role != "hub":
            keep &= ~np.isfinite(scene.triangles[role].distances(centre, distance))
    return keep


def box_postures(
    points: np.ndarray, n: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Tips uniform in the scene's bounding box, axes uniform on the upper half sphere."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    tip = lo + rng.random((n, 3)) * (hi - lo)
    axis = rng.normal(size=(n, 3))
    axis[:, 2] = np.abs(axis[:, 2])
    return tip, axis / np.linalg.norm(axis, axis=1)[:, None]


def clearance_rate(scene: CollisionScene, tool: Tool, tip: np.ndarray, axis: np.ndarray) -> None:
    """Postures/s with the shank+holder clearance: exact (fcl distance) vs capped at 5 mm."""
    n = len(tip)
    t_plain, _, plain = best_time(lambda: plain_fcl_check(scene, tool, tip, axis), 1)
    t_exact, _, exact = best_time(lambda: scene.check_postures(tool, tip, axis), 1)
    scene.check_postures(tool, tip[:1], axis[:1], clearance_cap=5.0)  # builds the grown tool
    t_cap, _, capped = best_time(
        lambda: scene.check_postures(tool, tip, axis, clearance_cap=5.0), 1
    )
    worst = float(np.max(np.abs(exact.clearance - plain.clearance)))
    below = exact.clearance <= 5.0
    worst_cap = float(np.max(np.abs(capped.clearance[below] - exact.clearance[below]), initial=0))
    # above the cap the value is a lower bound: never above the exact clearance
    wrong = int(np.sum(capped.clearance[~below] > exact.clearance[~below] + 1e-9))
    print(
        f"{'clearance':<14} n={n:6d}  plain fcl loop {n / t_plain:9.0f}/s  "
        f"CollisionScene exact {n / t_exact:9.0f}/s (ratio {t_plain / t_exact:4.2f}x, "
        f"max |diff| {worst:.1e} mm)  capped at 5 mm {n / t_cap:9.0f}/s "
        f"(ratio {t_plain / t_cap:4.2f}x, max |diff| below cap {worst_cap:.1e} mm, "
        f"bounds above the exact value {wrong}; fcl distances {capped.checks['distance']} "
        f"of {exact.checks['distance']})"
    )


def best_time(
    function: Callable[[], PostureReport], repeat: int
) -> tuple[float, float, PostureReport]:
    """Smallest CPU time and smallest wall time of ``repeat`` calls, and the last result.

    CPU time (``time.process_time``) is the primary measure: the machine is shared,
    and both sides are single-threaded.
    """
    cpu, wall, result = math.inf, math.inf, None
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        result = function()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    assert result is not None
    return cpu, wall, result


def run(
    label: str,
    scene: CollisionScene,
    tool: Tool,
    tip: np.ndarray,
    axis: np.ndarray,
    allowance: float,
    repeat: int,
) -> None:
    """Time both sides on the same postures; print rates, ratio and differing answers."""
    scene.check_postures(tool, tip[:10], axis[:10], cutter_allowance=allowance)  # warm up
    t_fast, w_fast, fast = best_time(
        lambda: scene.check_postures(
            tool, tip, axis, cutter_allowance=allowance, clearance=False
        ),
        repeat,
    )
    t_plain, w_plain, plain = best_time(
        lambda: plain_fcl_check(
            scene, tool, tip, axis, cutter_allowance=allowance, clearance=False
        ),
        repeat,
    )
    differ = int(
        np.sum(
            (fast.collides != plain.collides)
            | (fast.part != plain.part)
            | np.array([x != y for x, y in zip(fast.hit_role, plain.hit_role, strict=True)])
        )
    )
    n = len(tip)
    print(
        f"{label:<14} n={n:6d}  hits={int(fast.collides.sum()):5d}  "
        f"plain fcl loop {n / t_plain:9.0f}/s  CollisionScene {n / t_fast:9.0f}/s  "
        f"ratio {t_plain / t_fast:5.2f}x (wall {w_plain / w_fast:4.2f}x)  differing {differ}  "
        f"(fcl calls {fast.checks.get('collide', 0)}, "
        f"definite hits {fast.checks.get('definite_hits', 0)})"
    )


def finishing_check(fixture: str, tool_name: str, passages: int | None) -> None:
    """Every posture of a finishing run (paths' postures and the sub-samples of the
    motions between them): CollisionScene against the plain loop."""
    from cam.collision.postures import subdivide_motion
    from cam.finishing.options import FinishOptions
    from cam.finishing.plan import plan_finishing
    from cam.finishing.scene import solid_meshes
    from geometry.impeller import Impeller
    from geometry.spec import load_spec
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    impeller = Impeller(load_spec(ROOT / "fixtures" / "impellers" / fixture / "spec.toml"))
    options = FinishOptions.from_mapping(dict(scallop_mm=0.5, point_spacing_mm=1.5,
                                              clearance_mm=2.5, clearance_exact_mm=3.0,
                                              passages=passages))
    scene = CollisionScene(solid_meshes(impeller, options.tessellation_mm))
    tool = resolve_tool(tool_name)
    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml"))
    result = plan_finishing(impeller.surfaces, tool, kins, scene, options, scene_source="solid")
    step = math.radians(options.motion_step_deg)
    subs = [subdivide_motion(p.tip, p.axis, options.motion_step_mm, step)[:2]
            for p in result.paths if len(p.tip) > 1]
    tip = np.concatenate([t for t, _ in subs])
    axis = np.concatenate([a for _, a in subs])
    cap, allowance = options.clearance_exact_mm, options.cutter_allowance_mm
    c0, w0 = time.process_time(), time.perf_counter()
    fast = scene.check_postures(tool, tip, axis, cutter_allowance=allowance, clearance_cap=cap,
                                clearance_limits=(options.clearance_mm,))
    c1, w1 = time.process_time(), time.perf_counter()
    plain = plain_fcl_check(scene, tool, tip, axis, cutter_allowance=allowance)
    c2, w2 = time.process_time(), time.perf_counter()
    differ = int(np.sum((fast.collides != plain.collides) | (fast.part != plain.part))
                 + sum(a != b for a, b in zip(fast.hit_role, plain.hit_role, strict=True)))
    below = plain.clearance < cap
    worst = float(np.max(np.abs(fast.clearance[below] - plain.clearance[below]), initial=0.0))
    bound_ok = bool(np.all(fast.clearance[~below] >= cap - 1e-9))
    limit_differ = int(np.sum((fast.clearance < options.clearance_mm)
                              != (plain.clearance < options.clearance_mm)))
    print(f"{fixture} finishing, passages {passages or 'all'}, {tool.name}: "
          f"{sum(len(p.tip) for p in result.paths)} path postures, with the motion "
          f"sub-samples {len(tip)} postures, "
          f"hits {int(plain.collides.sum())}, differing hit/miss/part/role {differ}, "
          f"clearance below {cap} mm: {int(below.sum())} postures, largest |fast - fcl| "
          f"{worst:.2e} mm; above: lower bound holds {bound_ok}; "
          f"differing 'clearance < {options.clearance_mm}' {limit_differ}; "
          f"CPU fast {c1 - c0:.1f} s, plain {c2 - c1:.1f} s "
          f"(wall {w1 - w0:.1f} / {w2 - w1:.1f} s); checks {fast.checks}")


def cutting_postures(folder: Path) -> tuple[dict[str, Any], list[tuple[str, str, np.ndarray,
                                                                        np.ndarray]]]:
    """finish.json of ``folder`` and, per operation, the tool name and the cutting
    postures of its APT file with the motions between them sub-sampled.

    A cutting pass is a plunge (approach) target and the feed moves after it; the
    motion is sub-sampled as the planner checks it (``subdivide_motion`` at the
    options' ``motion_step_mm`` / ``motion_step_deg``).
    """
    import json

    from cam.collision.postures import subdivide_motion
    from postproc.apt import read_apt
    from postproc.toolpath import MoveKind

    document = json.loads((folder / "finish.json").read_text())
    options = document["options"]
    step_mm, step_rad = options["motion_step_mm"], math.radians(options["motion_step_deg"])
    out = []
    for name, op in document["operations"].items():
        tips, axes = [], []
        for toolpath in read_apt(folder / op["apt"]):
            cutting = np.isin(toolpath.kind, (MoveKind.FEED, MoveKind.PLUNGE))
            # runs of cutting moves: a pass starts at its plunge target
            edges = np.flatnonzero(np.diff(np.r_[False, cutting, False].astype(np.int8)))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                tip, axis = toolpath.tip[a:b], toolpath.axis[a:b]
                if len(tip) > 1:
                    tip, axis, _ = subdivide_motion(tip, axis, step_mm, step_rad)
                tips.append(tip)
                axes.append(axis)
        out.append((name, op["tool"]["name"], np.concatenate(tips), np.concatenate(axes)))
    return document, out


def apt_check(folder: Path) -> None:
    """Every cutting posture (and motion sub-sample) of a finishing folder's APT files:
    CollisionScene against the plain loop, per operation with its tool."""
    from cam.finishing.scene import solid_meshes
    from geometry.impeller import Impeller
    from geometry.spec import load_spec

    document, operations = cutting_postures(folder)
    options = document["options"]
    spec = Path(document["spec"])
    spec = spec if spec.is_absolute() else ROOT / spec
    scene = CollisionScene(solid_meshes(Impeller(load_spec(spec)), options["tessellation_mm"]))
    compare_operations(scene, operations, options, str(document["spec"]))


def compare_operations(scene: CollisionScene,
                       operations: list[tuple[str, str, np.ndarray, np.ndarray]],
                       options: dict[str, Any], label: str) -> None:
    """Per operation ``(name, tool name, tips (n, 3), axes (n, 3))``: CollisionScene
    against the plain loop at the options' cap, clearance limit and cutter allowance;
    prints each and the totals."""
    cap, limit = options["clearance_exact_mm"], options["clearance_mm"]
    allowance = options["cutter_allowance_mm"]
    totals = {"postures": 0, "hits": 0, "differing": 0, "below": 0, "limit": 0}
    worst_all, bound_all = 0.0, True
    for name, tool_name, tip, axis in operations:
        tool = resolve_tool(tool_name)
        c0 = time.process_time()
        fast = scene.check_postures(tool, tip, axis, cutter_allowance=allowance,
                                    clearance_cap=cap, clearance_limits=(limit,))
        c1 = time.process_time()
        plain = plain_fcl_check(scene, tool, tip, axis, cutter_allowance=allowance)
        c2 = time.process_time()
        differ = int(np.sum((fast.collides != plain.collides) | (fast.part != plain.part))
                     + sum(a != b for a, b in zip(fast.hit_role, plain.hit_role, strict=True)))
        below = plain.clearance < cap
        worst = float(np.max(np.abs(fast.clearance[below] - plain.clearance[below]),
                             initial=0.0))
        bound_ok = bool(np.all(fast.clearance[~below] >= cap - 1e-9))
        limit_differ = int(np.sum((fast.clearance < limit) != (plain.clearance < limit)))
        for key, value in (("postures", len(tip)), ("hits", int(plain.collides.sum())),
                           ("differing", differ), ("below", int(below.sum())),
                           ("limit", limit_differ)):
            totals[key] += value
        worst_all, bound_all = max(worst_all, worst), bound_all and bound_ok
        hits = int(plain.collides.sum())
        print(f"{name:9s} {tool.name:12s} postures {len(tip):7d}  hits {hits:4d}"
              f"  differing hit/miss/part/role {differ}  below {cap:g} mm {int(below.sum()):6d}"
              f"  largest |fast - fcl| {worst:.2e} mm  lower bound above holds {bound_ok}"
              f"  differing '< {limit:g}' {limit_differ}  CPU fast {c1 - c0:.1f} s,"
              f" plain {c2 - c1:.1f} s", flush=True)
    print(f"{label}: {totals['postures']} postures, hits {totals['hits']}, "
          f"differing hit/miss/part/role {totals['differing']}, clearances below "
          f"{cap:g} mm {totals['below']} (largest |fast - fcl| {worst_all:.2e} mm), above: "
          f"lower bound holds {bound_all}, differing '< {limit:g}' {totals['limit']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--finishing", default=None, help="fixture: check its finishing")
    parser.add_argument("--finish-tool", default="ball6_taper")
    parser.add_argument("--apt", default=None, type=Path,
                        help="a finishing folder (finish.json + APT files): check its postures")
    parser.add_argument("--passages", type=int, default=None, help="--finishing: passages")
    parser.add_argument("--postures", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--tool", default="ball6_taper")
    parser.add_argument("--repeat", type=int, default=3, help="best of N timings per side")
    parser.add_argument(
        "--synthetic", action="store_true",
        help="the synthetic nine-blade impeller (24k triangles) even if the fixture builds",
    )
    parser.add_argument(
        "--dense", action="store_true",
        help="the synthetic impeller tessellated finely (about 512k triangles) instead",
    )
    args = parser.parse_args()
    if args.apt is not None:
        apt_check(args.apt)
        return
    if args.finishing:
        finishing_check(args.finishing, args.finish_tool, args.passages)
        return
    if args.dense:
        meshes, source = dense_meshes()
    elif args.synthetic:
        meshes, source = impeller_meshes(9), "synthetic nine-blade impeller (--synthetic)"
    else:
        meshes, source = load_scene_meshes()
    tool = resolve_tool(args.tool)
    roles = ", ".join(f"{k} ({len(m.faces)} tri)" for k, m in meshes.items())
    print(f"scene: {source}\nroles: {roles}")
    print(f"tool: {tool.name}")
    t0 = time.perf_counter()
    scene = CollisionScene(meshes)
    scene.tool_model(tool, -0.05)
    print(f"scene set-up {time.perf_counter() - t0:.2f} s (not counted below)")
    rng = np.random.default_rng(args.seed)
    hub = meshes.get("hub", next(iter(meshes.values())))
    tip, axis = hub_postures(hub, tool.radius, args.postures, rng, lift=0.0)
    run("hub contact", scene, tool, tip, axis, 0.05, args.repeat)
    keep = in_passage(scene, tip + tool.radius * axis, tool.radius + 0.5)
    run("finishing-like", scene, tool, tip[keep], axis[keep], 0.05, args.repeat)
    tip, axis = hub_postures(hub, tool.radius, args.postures, rng, lift=20.0)
    run("approach", scene, tool, tip, axis, 0.05, args.repeat)
    tip, axis = box_postures(np.vstack([m.vertices for m in meshes.values()]), args.postures, rng)
    run("random", scene, tool, tip, axis, 0.0, args.repeat)
    few = max(1, args.postures // 10)
    clearance_rate(scene, tool, tip[:few], axis[:few])


if __name__ == "__main__":
    main()
