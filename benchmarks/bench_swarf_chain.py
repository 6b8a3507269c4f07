"""Swarf finishing in a chain run: passage 0's faces, the passes, the cycle (issue 23).

A chain run (``impeller-cam run``) with ``[machining.finish] blade_strategy =
"swarf_or_point"`` and ``passages = 1`` finishes passage 0 only; its verification
(``verify/finish/stock.npz``, the chain's resolution) then holds the finished faces
of passage 0 beside the roughed others. This script reads that run:

* **faces** (``passage_regions``): the chain's per-face summary
  (``cam.run.regions.region_summary``: allowance = the finishing scallop, gouge
  tolerance, the strips next to the fillets apart) on the samples of passage 0's
  faces only -- the pressure side and edges of blade 0 (passage 0's edge passes wrap
  them), the suction side of blade 1 (and the splitter between, both sides), the
  hub and fillets between (``pitch_position`` 0..1); plus blade 0's edges by half
  (the half facing passage 0; the other borders the last passage's wall);
* **passes** (``swarf_passes``): the samples the swarf program made, measured per
  pass against the exact side and the prediction
  (``cam.finishing.swarf_verify.measure_passes``; the prediction re-made from
  finish.json's options): the two ranges, and sample by sample (``pointwise``);
* **edges** (``edges_by_symmetry``): blade 0's edges as a run of every passage would
  leave them: its own samples and blade 1's turned back by one pitch (what the last
  passage's operations leave there), the smaller of the two;
* **cycle**: the motion stage's cycle times (blended and exact stop) of every finish
  NC program of the run.

Run: ``python benchmarks/bench_swarf_chain.py OUT SPEC`` (OUT: the chain's output
folder, SPEC: the spec it ran); writes ``OUT/swarf_chain.json`` (``--skip``: stages
kept from an earlier run of it).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree


def pitch_position(points: NDArray[np.float64], spec: Any) -> NDArray[np.float64]:
    """Angular position of points from blade 0's camber, in pitches.

    ``wrap(theta - theta_0(r, z)) / pitch`` with ``theta_0`` the camber angle of blade
    0 at the nearest ``(r, z)`` of a 400 x 200 camber grid: 0 on blade 0, 1 on blade
    1, passage 0 between (range -0.5 to blades - 0.5).

    Parameters
    ----------
    points : (n, 3) float64
        mm.
    spec : ImpellerSpec

    Returns
    -------
    (n,) float64
    """
    from geometry.surfaces import build_surfaces

    grid = build_surfaces(spec).blades[0].grid(400, 200, "camber").reshape(-1, 3)
    tree = cKDTree(np.c_[np.hypot(grid[:, 0], grid[:, 1]), grid[:, 2]])
    _, nearest = tree.query(np.c_[np.hypot(points[:, 0], points[:, 1]), points[:, 2]])
    theta = np.arctan2(grid[:, 1], grid[:, 0])[nearest]
    d = (np.arctan2(points[:, 1], points[:, 0]) - theta) / float(spec.pitch)
    return np.asarray((d + 0.5) % spec.blades - 0.5)


def passage_regions(out: Path, spec_path: Path) -> dict[str, Any]:
    """The chain's per-face summary on passage 0's faces (see the module docstring)."""
    from cam.run.regions import LATHE_ROLES, LabelledDesign, region_summary
    from cam.verify.deviation import Deviation
    from cam.verify.stock import Stock
    from geometry.spec import load_spec
    from impeller_cam.tolerances import DEFAULT_TOLERANCES

    spec = load_spec(spec_path)
    points, _, moves = Stock.load(out / "verify" / "finish" / "stock.npz").surface_samples()
    d = pitch_position(points, spec)
    near = (d > -0.4) & (d < 1.4)
    points, moves, d = points[near], moves[near], d[near]
    design = LabelledDesign(spec_path)
    signed, faces = design.distance.closest(points)
    role, splitter = design.face_roles[faces], design.face_splitter[faces]
    main = ~splitter
    blade0 = main & (np.abs(d) < 0.5)
    blade1 = main & (np.abs(d - 1.0) < 0.5)
    keep = (np.isin(role, ("hub", "fillet")) & (d > 0.0) & (d < 1.0)
            | blade0 & np.isin(role, ("pressure", "leading_edge", "trailing_edge"))
            | blade1 & (role == "suction")
            | splitter & (np.abs(d - 0.5) < 0.25)
            | np.isin(role, LATHE_ROLES) & (d > 0.0) & (d < 1.0))
    finish = json.loads((out / "finish" / "finish.json").read_text())
    allowance = float(finish["options"]["scallop_mm"])
    tolerance = DEFAULT_TOLERANCES.gouge
    radius = 0.5 * float(finish["tool"]["diameter_mm"])  # the chain's near-fillet strip
    summary = region_summary(
        design, Deviation(points[keep], signed[keep], moves[keep], faces[keep]), allowance,
        tolerance, radius, float(spec.stock_allowance))
    # blade 0's edges by half: the half facing passage 0 (d >= 0) is passage 0's; the
    # other half borders the suction side of blade 0, the last passage's wall
    for edge in ("leading_edge", "trailing_edge"):
        for half, side in (("passage0_half", d >= 0.0), ("other_half", d < 0.0)):
            values = signed[blade0 & (role == edge) & side]
            summary[f"blade0_{edge}_{half}"] = None if not len(values) else {
                "samples": int(len(values)), "limit_mm": allowance + tolerance,
                "max_mm": round(float(values.max()), 4),
                "p99_mm": round(float(np.percentile(values, 99)), 4),
                "min_mm": round(float(values.min()), 4),
                "over_limit": int((values > allowance + tolerance).sum())}
    return summary


def edges_by_symmetry(out: Path, spec_path: Path, match_mm: float = 0.1) -> dict[str, Any]:
    """Blade 0's edges as a run of every passage would leave them, from a ``passages =
    1`` run.

    Blade 0's edges are cut by passage 0's edge passes and by the operations of its
    two walls: its pressure side (passage 0's) and its suction side (the last
    passage's, not run). Blade 1's suction side is passage 0's wall: the programs of
    the last passage are those of passage 0 turned by one pitch back, so blade 1's
    edge samples turned by ``-pitch`` about the axis show what the last passage's
    operations leave on blade 0's edges. A run of every passage removes at least the
    union of the two, so at each of blade 0's edge samples ``min(own, turned)`` (the
    turned sample whose foot on the design is nearest its foot, within ``match_mm``)
    bounds what it leaves from above, up
    to the dexel sampling (the two sample sets are not the same points) and to the
    passages' postures differing by their own remedies.

    Returns
    -------
    dict
        Per edge: samples, matched, and ``own`` / ``combined`` max, p99 and the
        samples over the limit (allowance = the finishing scallop + the gouge
        tolerance), mm.
    """
    from cam.run.regions import LabelledDesign
    from cam.verify.stock import Stock
    from geometry.spec import load_spec
    from impeller_cam.tolerances import DEFAULT_TOLERANCES

    spec = load_spec(spec_path)
    points, _, _ = Stock.load(out / "verify" / "finish" / "stock.npz").surface_samples()
    d = pitch_position(points, spec)
    near = (d > -0.5) & (d < 1.5)
    points, d = points[near], d[near]
    design = LabelledDesign(spec_path)
    signed, faces = design.distance.closest(points)
    role, main = design.face_roles[faces], ~design.face_splitter[faces]
    # each sample's foot on the design (along its closest face's normal): samples of
    # a roughed surface lie millimetres off it, a finished one's on it
    normal = np.zeros((int(design.distance.source_face.max()) + 1, 3))
    normal[design.distance.source_face] = design.distance.normals
    foot = points - signed[:, None] * normal[faces]
    finish = json.loads((out / "finish" / "finish.json").read_text())
    limit = float(finish["options"]["scallop_mm"]) + DEFAULT_TOLERANCES.gouge
    c, s = math.cos(-float(spec.pitch)), math.sin(-float(spec.pitch))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def figures(values: NDArray[np.float64]) -> dict[str, Any]:
        return {"max_mm": round(float(values.max()), 4),
                "p99_mm": round(float(np.percentile(values, 99)), 4),
                "over_limit": int((values > limit).sum())}

    report: dict[str, Any] = {"limit_mm": limit, "match_mm": match_mm}
    for edge in ("leading_edge", "trailing_edge"):
        own = main & (np.abs(d) < 0.5) & (role == edge)
        other = main & (np.abs(d - 1.0) < 0.5) & (role == edge)
        if not own.any() or not other.any():
            report[edge] = None
            continue
        distance, index = cKDTree(foot[other] @ turn.T).query(foot[own])
        matched = distance <= match_mm
        turned = signed[other][index]
        combined = np.where(matched, np.minimum(signed[own], turned), signed[own])
        report[edge] = {"samples": int(own.sum()), "matched": int(matched.sum()),
                        "own": figures(signed[own]), "combined": figures(combined),
                        "combined_matched": figures(combined[matched])}
    return report


def swarf_passes(out: Path, spec_path: Path) -> dict[str, Any]:
    """The swarf program's samples in the finished stock against the prediction."""
    from cam.finishing.options import FinishOptions
    from cam.finishing.swarf_plan import swarf_walls
    from cam.finishing.swarf_verify import measure_passes, passes_of_program
    from cam.tools import resolve_tool
    from cam.verify.deviation import DesignDistance
    from cam.verify.sources import load_design
    from cam.verify.stock import Stock
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces
    from postproc.apt import read_apt

    finish = json.loads((out / "finish" / "finish.json").read_text())
    spec = load_spec(spec_path)
    tool = finish["tool"]["name"] if isinstance(finish["tool"], dict) else finish["tool"]
    walls = swarf_walls(build_surfaces(spec), resolve_tool(tool),
                        FinishOptions.from_mapping(finish["options"]))
    tips = np.vstack([tp.tip for tp in read_apt(out / "finish" / "finish_swarf.apt")])
    passes = passes_of_program(walls, tips)
    stock = Stock.load(out / "verify" / "finish" / "stock.npz")
    points, _, made = stock.surface_samples()
    names = np.array([name for name, _ in stock.owners], dtype=np.str_)
    swarf = np.zeros(len(points), dtype=bool)
    swarf[made >= 0] = np.char.startswith(names[made[made >= 0]], "finish_swarf")
    vertices, faces, _ = load_design(spec_path)
    design = DesignDistance(vertices, faces)
    collected: list[NDArray[np.float64]] = []
    found = measure_passes(walls, passes, points[swarf], spec.leading_edge,
                           spec.trailing_edge, design=design, collect=collected)
    everywhere = design(points[swarf])
    entries = []
    for m, (w, run), samples in zip(found, passes, collected, strict=True):
        entries.append({**m.as_dict(), **pointwise(walls[w], run, samples, spec)})
    return {"samples": int(swarf.sum()), "min_mm": float(everywhere.min()),
            "gouges": int((everywhere < -0.05).sum()),
            "passes": entries,
            "largest_difference_mm": max((m.difference for m in found), default=None),
            "prediction": finish.get("swarf")}


def pointwise(sw: Any, run: NDArray[np.intp], samples: NDArray[np.float64],
              spec: Any) -> dict[str, Any]:
    """Measured against predicted deviation at each measured sample, mm.

    The prediction (``swarf_sweep.pass_deviation``, as ``measure_passes`` makes it:
    the pass's own swept tool on its band, 61 points per ruling) interpolated at each
    sample's side parameters ``(p, v)`` (``samples``: ``measure_passes``' collected
    ``x, y, z, p, v, distance``).

    Returns
    -------
    dict
        ``pointwise_max_abs_mm`` and ``pointwise_p99_abs_mm`` of measured minus
        predicted (None without samples).
    """
    from scipy.interpolate import RegularGridInterpolator

    from cam.finishing.swarf_blade import side_segment
    from cam.finishing.swarf_sweep import pass_deviation

    if not len(samples):
        return {"pointwise_max_abs_mm": None, "pointwise_p99_abs_mm": None}
    role = "pressure" if sw.wall.side > 0 else "suction"
    seg = side_segment(sw.wall.blade, role, spec.leading_edge, spec.trailing_edge)
    res = sw.result
    u = res.postures.u

    def point(q: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(seg.point(q, s * np.interp(q, u, res.v_bottom)))

    field = pass_deviation(point, res.flank, res.postures, run, samples=61)
    order = np.argsort(field.u)
    grid = RegularGridInterpolator((field.u[order], field.v), field.deviation[order],
                                   bounds_error=False, fill_value=None)
    p, v, measured = samples[:, 3], samples[:, 4], samples[:, 5]
    s = v / np.interp(p, u, res.v_bottom)
    difference = np.abs(measured - grid(np.column_stack([p, s])))
    return {"pointwise_max_abs_mm": float(difference.max()),
            "pointwise_p99_abs_mm": float(np.percentile(difference, 99))}


def cycle(out: Path, machine_path: Path) -> dict[str, Any]:
    """Cycle times of every finish NC program of the run, s: the motion stage's
    (``program_file_times``: ``cycle_time_s`` blended within G64 P, ``exact_stop_s``
    a jerk-limited stop at every block, ``nominal_s``) and the blocks."""
    from cam.motion.breakdown import program_file_times
    from postproc.machine import load_machine

    machine = load_machine(machine_path)
    times = {}
    for program in json.loads((out / "nc" / "post.json").read_text())["programs"]:
        if program["operation"] != "finish":
            continue
        found = program_file_times(out / program["nc"], out / program["apt"], machine)
        times[program["name"]] = {key: round(float(found[key]), 2) if key != "blocks"
                                  else int(found[key])
                                  for key in ("cycle_time_s", "exact_stop_s", "nominal_s",
                                              "blocks")}
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the chain's output folder")
    parser.add_argument("spec", type=Path, help="the spec it ran")
    parser.add_argument("--machine", type=Path, default=Path(__file__).resolve().parents[1]
                        / "fixtures" / "machines" / "trunnion-500.toml")
    parser.add_argument("--skip", nargs="*", default=[],
                        choices=["faces", "passes", "cycle", "edges"])
    args = parser.parse_args()
    target = args.out / "swarf_chain.json"
    report: dict[str, Any] = json.loads(target.read_text()) if target.is_file() else {}
    report.update(out=str(args.out), spec=str(args.spec))  # stages skipped keep theirs
    for name, stage in (("cycle", lambda: cycle(args.out, args.machine)),
                        ("faces", lambda: passage_regions(args.out, args.spec)),
                        ("passes", lambda: swarf_passes(args.out, args.spec)),
                        ("edges", lambda: edges_by_symmetry(args.out, args.spec))):
        if name in args.skip:
            continue
        start = time.perf_counter()
        report[name] = stage()
        report[f"{name}_wall_s"] = round(time.perf_counter() - start, 1)
        target.write_text(json.dumps(report, indent=1, default=str))
        print(json.dumps({name: report[name]}, default=str)[:4000], flush=True)


if __name__ == "__main__":
    main()
