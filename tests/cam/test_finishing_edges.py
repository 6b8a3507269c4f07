"""Edge finishing (issue 28): passes round the leading and trailing edges, hub to tip.

* The lean direction ``edge outward + SIDE_SHARE n`` turns monotonically round the
  edge and every default posture leans off the surface at its contact (the flutes
  above the ball stay off the edge); cut and round edges are both wrapped.
* Coverage: the swept balls of the passes leave at most the scallop on the edge
  pieces above the root (cut trailing edge of the small fixture, round edges of the
  round_te fixture).
* The main job's gouges (slow): on nine_blade the old lean (towards the local contact
  normal, which turns by 180 deg round the edge) went through smoothing, the eq. 7
  remedy and the repair and ended leaning *into* the leading edge; the flutes then
  cut into it although the planner's check (cutter shrunk by the cutter allowance)
  passed them. ``edge_plan.plan_edges`` keeps every posture leaning off the edge and
  the flutes outside the blade.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cam.finishing.edge_paths import SIDE_SHARE, edge_levels
from cam.finishing.edge_plan import MIN_LEAN_DEG, lean_at_contact
from cam.finishing.fillet_cover import edge_samples, material_left
from cam.finishing.options import scallop_stepover
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces

ROOT = Path(__file__).resolve().parents[2]
IMPELLERS = ROOT / "fixtures" / "impellers"


def _spec(name: str) -> Path:
    return IMPELLERS / name / "spec.toml"


@pytest.mark.parametrize("name", ["small", "round_te"])
def test_the_lean_turns_monotonically_and_keeps_the_flutes_off(name: str) -> None:
    """Per level the lean direction turns one way round the edge (angle from the start
    grows monotonically, to 0.5 deg, at most 2 atan(SIDE_SHARE) + the edge's own twist), and every
    posture leans off the surface at its contact."""
    surfaces = build_surfaces(load_spec(_spec(name)))
    levels = edge_levels(surfaces, 2.0, 0.8, 0.5)
    assert {lv.path.name.split(".")[3] for lv in levels} == {"leading_edge", "trailing_edge"}
    for level in levels:
        across = level.across
        turned = np.degrees(np.arccos(np.clip(across @ across[0], -1.0, 1.0)))
        # monotone but for a concave side's own bend on its overlap and a cut edge's
        # corner junctions (up to 0.27 deg back)
        assert (np.maximum.accumulate(turned) - turned).max() < 0.5, level.path.name
        assert turned[-1] <= 2.0 * math.degrees(math.atan(SIDE_SHARE)) + 5.0
        lean = lean_at_contact(level.path.reference_axis, level.path.normal)
        assert lean.min() > 2.0, (level.path.name, float(lean.min()))


@pytest.mark.parametrize("name", ["small", "round_te"])
def test_edge_passes_cover_cut_and_round_edges(name: str) -> None:
    """The balls of the edge passes (centres densified along each pass) leave at most
    the scallop height on the edge pieces more than a ball diameter above the hub (the
    root is the fillet passes' part): the small fixture's cut trailing edge (corner,
    face, corner) and the round edges of the round_te fixture."""
    surfaces = build_surfaces(load_spec(_spec(name)))
    radius, scallop = 2.0, 0.1
    levels = edge_levels(surfaces, radius, scallop_stepover(radius, scallop), 0.5)
    centres = [lv.path.centre for lv in levels]
    for edge in ("leading_edge", "trailing_edge"):
        samples = edge_samples(surfaces, surfaces.blades[0], edge, radius, 60, 16)
        keep = surfaces.hub.signed_distance(samples) > 2.0 * radius
        assert keep.sum() > 100
        left = material_left(samples[keep], centres, radius)
        assert left.max() <= scallop + 0.01, (edge, float(left.max()))


def _flute_gap(blade: object, centre: np.ndarray, axis: np.ndarray, radius: float,
               length: float) -> np.ndarray:
    """Distance of the flutes' axis points (ball centre up to ``length``) from the
    blade (``paths.body_distance``, exact for round edges) minus the radius, per posture."""
    from cam.finishing.paths import body_distance

    heights = np.linspace(0.0, length, 41)
    points = centre[:, None, :] + heights[None, :, None] * axis[:, None, :]
    gap = body_distance(blade, points.reshape(-1, 3)).reshape(len(centre), len(heights))
    return np.asarray(gap.min(axis=1) - radius)


@pytest.mark.slow
def test_nine_blade_leading_edge_flutes_stay_off_the_edge() -> None:
    """The main job's gouge, reproduced on nine_blade's lowest leading-edge level
    (trunnion-500, ball6_taper, shank and holder 2.5 mm off the design as in the
    chain): the old postures (lean 5 deg towards the local contact normal) come out of
    the M3 procedure leaning into the edge, and their flutes reach more than the
    tessellation into the blade while the planner's check (cutter shrunk by 0.05 mm)
    finds no collision; ``plan_edges`` leans the level further off the edge (no
    remedy, no repair) and keeps every posture leaning off and the flutes outside."""
    from cam.collision import CollisionScene
    from cam.finishing.edge_plan import plan_edges
    from cam.finishing.fillet_paths import lean_away
    from cam.finishing.fillet_plan import finish_trimmed
    from cam.finishing.options import FinishOptions
    from cam.finishing.scene import solid_meshes
    from cam.tools import resolve_tool
    from geometry.impeller import Impeller
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    impeller = Impeller(load_spec(IMPELLERS / "nine_blade" / "spec.toml"))
    surfaces = impeller.surfaces
    options = FinishOptions.from_mapping(dict(scallop_mm=0.5, point_spacing_mm=1.5,
                                              clearance_mm=2.5, clearance_exact_mm=3.0,
                                              passages=1))
    tool = resolve_tool("ball6_taper")
    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml"))
    scene = CollisionScene(solid_meshes(impeller, options.tessellation_mm))
    level = edge_levels(surfaces, tool.radius, scallop_stepover(tool.radius, 0.5), 1.5)[0]
    assert level.path.name.endswith("leading_edge.01")
    blade = surfaces.blades[0]
    flutes = tool.flute_length - tool.radius
    # the old postures
    old = replace(level.path, reference_axis=lean_away(level.ruling, level.path.normal,
                                                       math.radians(5.0)),
                  away=level.path.normal)
    before = finish_trimmed(old, tool, kins, scene, options, surfaces)
    assert before.interference.interfering_points.size == 0  # the planner saw nothing
    assert lean_at_contact(before.axis, before.path.normal).min() < -1.0
    centre = before.tip + tool.radius * before.axis
    assert _flute_gap(blade, centre, before.axis, tool.radius, flutes).min() < -0.03
    # the new plan
    result = plan_edges(surfaces, tool, kins, scene, options, scene_source="solid")
    first = next(p for p in result.paths if p.path.name == level.path.name)
    assert first.interference.delta_c == 0 and first.repair is None
    for path in result.paths:
        assert path.interference.interfering_points.size == 0, path.path.name
        assert lean_at_contact(path.axis, path.path.normal).min() >= MIN_LEAN_DEG
        if ".leading_edge." in path.path.name:
            centre = path.tip + tool.radius * path.axis
            gap = _flute_gap(blade, centre, path.axis, tool.radius, flutes)
            assert gap.min() > -0.02, (path.path.name, float(gap.min()))
