"""Benchmark: fillet and edge finishing on one passage, and what they leave (issue 28).

On a spec (default nine_blade) at the main job's finishing settings (the spec's
``[machining.finish]`` table, ``clearance_mm`` = 0.5 + the roughed stock as
``cam/run/stages.py`` ``finish_options`` adds it, machine trunnion-500) it plans, for
``--passages`` passages (default 1):

* the fillet pencil passes (``plan_fillet``) with the fillet tool (``--fillet-tool``,
  default the library's largest ball no larger than the fillet), and
* the edge passes (``plan_edges``) with the spec's finishing tool,

through the whole M3 procedure against the built solid's meshes, prints collisions,
reversals, least clearance, repaired and shortened postures, and measures
(``cam.finishing.fillet_cover``) what the swept balls leave

* on the fillet of each passage-0 wall (fillet passes alone), and
* on blade 1's leading edge (and a round trailing edge) above the finishing ball's
  hub contact: edge passes alone, and with ``--passages 2`` or more edge plus fillet
  passes (blade 0 with one passage).

No dexels: the verification gives the whole part's figures (``impeller-cam run``).
Run::

    .venv/bin/python benchmarks/bench_fillet.py [SPEC] [--machine M] [--passages N]
        [--fillet-tool NAME]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    from cam.collision import CollisionScene
    from cam.finishing.edge_plan import plan_edges
    from cam.finishing.fillet_cover import edge_samples, fillet_samples, material_left
    from cam.finishing.fillet_plan import choose_fillet_tool, plan_fillet
    from cam.finishing.options import FinishOptions
    from cam.finishing.paths import passage_walls
    from cam.finishing.scene import solid_meshes
    from cam.run.settings import resolve_settings
    from cam.tools import resolve_tool
    from geometry.impeller import Impeller
    from geometry.spec import load_spec
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", nargs="?",
                        default=str(ROOT / "fixtures/impellers/nine_blade/spec.toml"))
    parser.add_argument("--machine", default=str(ROOT / "fixtures/machines/trunnion-500.toml"))
    parser.add_argument("--passages", type=int, default=1)
    parser.add_argument("--fillet-tool", default=None)
    args = parser.parse_args()

    spec = load_spec(args.spec)
    settings = resolve_settings(args.spec)
    stock = max(spec.finishing_allowance + float(settings.rough.get("scallop_mm", 0.5)),
                spec.stock_allowance)
    values = {**settings.finish, "passages": args.passages}
    values["clearance_mm"] = float(values.get("clearance_mm", 0.5)) + stock
    values["clearance_exact_mm"] = max(3.0, values["clearance_mm"])
    options = FinishOptions.from_mapping(values)
    main_tool = resolve_tool(settings.finish_tool)
    fillet_tool = resolve_tool(args.fillet_tool) if args.fillet_tool else \
        choose_fillet_tool(spec.fillet_radius)
    start = time.perf_counter()
    impeller = Impeller(spec)
    scene = CollisionScene(solid_meshes(impeller, options.tessellation_mm))
    kins = kinematics_for(load_machine(args.machine))
    surfaces = impeller.surfaces
    print(f"{spec.name}: r_f {spec.fillet_radius} mm, edges {spec.leading_edge}/"
          f"{spec.trailing_edge}, clearance {options.clearance_mm:g} mm, scallop "
          f"{options.scallop_mm:g} mm; solid and scene {time.perf_counter() - start:.0f} s")
    runs = {}
    if fillet_tool is not None:
        runs["fillet"] = (fillet_tool, plan_fillet(surfaces, fillet_tool, main_tool.radius,
                                                   kins, scene, options, scene_source="solid"))
    runs["edge"] = (main_tool, plan_edges(surfaces, main_tool, kins, scene, options,
                                          scene_source="solid"))
    centres = {}
    for name, (tool, result) in runs.items():
        s = result.summary()
        trimmed = sum(p.trimmed for p in result.paths)
        print(f"{name} ({tool.name}): {s['paths']} paths, {s['points']} points, collisions "
              f"{s['collisions']}, motion {s['motion_collisions']}, reversals "
              f"{s['reversals_after']}, least clearance {s['min_clearance_mm']} mm, "
              f"repaired {s['posture_repairs']['tilted_points']} postures, "
              f"{trimmed} postures cut at pass ends, unresolved {s['smaller_tool_needed']}")
        centres[name] = [p.tip + tool.radius * p.axis for p in result.paths]
    h = options.scallop_mm
    if "fillet" in runs:
        for wall in [w for pair in passage_walls(surfaces) for w in pair]:
            left = material_left(fillet_samples(surfaces, wall, 2000, 25), centres["fillet"],
                                 runs["fillet"][0].radius)
            print(f"fillet {wall.label}: max {left.max():.3f} p99 "
                  f"{np.percentile(left, 99):.3f} mm, {(left > h).sum()} of {len(left)} "
                  f"samples over {h:g}")
    edges = ["leading_edge"] + (["trailing_edge"] if spec.trailing_edge == "round" else [])
    # blade 1's edges: its suction-side fillet is passage 0's, its pressure side and its
    # edge passes passage 1's (blade 0 when only passage 0 is planned)
    blade = surfaces.blades[1 if args.passages > 1 and len(surfaces.blades) > 1 else 0]
    for edge in edges:
        samples = edge_samples(surfaces, blade, edge, main_tool.radius, 600, 40)
        left = material_left(samples, centres["edge"], main_tool.radius)
        line = (f"{edge}: edge passes max {left.max():.3f} mm, {(left > h).sum()} of "
                f"{len(left)} over")
        if "fillet" in runs and args.passages > 1:
            both = np.minimum(left, material_left(samples, centres["fillet"],
                                                  runs["fillet"][0].radius))
            line += (f"; with the fillet passes max {both.max():.3f} p99 "
                     f"{np.percentile(both, 99):.3f} mm, {(both > h).sum()} over")
        print(line)
    print(f"total {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
