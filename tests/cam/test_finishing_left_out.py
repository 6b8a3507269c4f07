"""Postures the repair cannot free are left out of the cut, named (issues 28 and 18).

A blade pass runs past a wall as tall as the tool (the splitter's outlet pattern,
tests/cam/test_finishing_repair.py's tall wall, here 24 mm long): near it the
holder's collar needs a tilt of about 16 deg. With the cone search capped at 10 deg
the repair leaves those postures colliding; they are left out, the pass is cut into
its clean pieces (each re-checked independently), and every point left out is named.
With the default search the repair frees them all and nothing is left out.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.interference import check_path
from cam.finishing.options import FinishOptions
from cam.finishing.order import ordered_passes
from cam.finishing.paths import CutterPath
from cam.finishing.pieces import cut_short_entry, finish_runs, offenders
from cam.finishing.plan import FinishResult, finish_path
from cam.tools import resolve_tool
from postproc.kinematics import Kinematics, kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
TOOL = resolve_tool("ball4_taper")  # R 2, holder collar radius 25 from 85 mm up
#: Half the wall's length along the pass (Y), mm.
WALL_HALF = 12.0


@pytest.fixture(scope="module")
def kins() -> Kinematics:
    return kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml"))


@pytest.fixture(scope="module")
def scene() -> CollisionScene:
    """A plate x in [-1, 0], |y| <= WALL_HALF, z in [0, 110]."""
    tall = trimesh.creation.box(extents=[1.0, 2.0 * WALL_HALF, 110.0])
    tall.apply_translation([-0.5, 0.0, 55.0])
    return CollisionScene({"wall": tall}, grid_spacing=2.0)


def wall_pass(n: int = 21, half: float = 60.0) -> CutterPath:
    """Ball centres 2.6 mm off the plate along Y; the axis leaned 2 deg along the feed
    (A not singular); the opposite wall close (Cmax about 3 deg: turning C cannot
    help)."""
    centre = np.column_stack([np.full(n, 2.6), np.linspace(-half, half, n), np.full(n, 5.0)])
    lean = math.radians(2.0)
    up = np.tile([0.0, math.sin(lean), math.cos(lean)], (n, 1))
    off = np.tile([1.0, 0.0, 0.0], (n, 1))
    return CutterPath(name="p0.blade.wall.01", operation="blade", passage=0, centre=centre,
                      normal=off, reference_axis=up, away=off,
                      opposite_tip=centre + [2.0, 0.0, 40.0], curve_u=np.linspace(0, 1, n))


def test_postures_the_repair_cannot_free_are_left_out_and_named(
        scene: CollisionScene, kins: Kinematics) -> None:
    options = FinishOptions(tilt_search_deg=10.0)
    path = wall_pass()
    whole = finish_path(path, TOOL, kins, scene, options)
    assert whole.repair is not None and whole.repair.unresolved.size  # the old result
    assert whole.interference.collides.any()
    beside = np.flatnonzero(np.abs(path.centre[:, 1]) <= WALL_HALF)

    pieces, lost = finish_runs(path, TOOL, kins, scene, options, None)
    assert pieces and lost.size
    assert set(beside.tolist()) <= set(lost.tolist())
    # the pieces and the points left out partition the pass, in pass order
    cut = np.concatenate([p.path.centre for p in pieces])
    kept = np.setdiff1d(np.arange(len(path)), lost)
    assert cut == pytest.approx(path.centre[kept], abs=1e-12)
    assert sum(len(p.path) for p in pieces) + lost.size == len(path)
    for piece in pieces:
        assert not offenders(piece).size, piece.path.name
        # re-checked independently: no posture nor move closer than the clearance
        again = check_path(scene, TOOL, piece.tip, piece.axis, options)
        assert not again.interfering_points.size, piece.path.name
        assert again.clearance.min() >= options.clearance_mm
        assert piece.tip + TOOL.radius * piece.axis == pytest.approx(
            piece.path.centre, abs=1e-9)
    summary = FinishResult(pieces, TOOL, options, "test").summary()
    assert summary["collisions"] == summary["motion_collisions"] == 0
    entry = cut_short_entry(path, lost)
    assert entry["path"] == "p0.blade.wall.01" and entry["operation"] == "blade"
    assert entry["left_out"] == lost.tolist() and not entry["dropped"]
    assert np.array(entry["centres_mm"]) == pytest.approx(path.centre[lost], abs=1e-3)
    # clean on both sides of the wall: pieces named <pass>.<k>, machined as one pass
    # (one direction), each after the first entered from the air
    assert len(pieces) >= 2
    assert [p.path.name for p in pieces] == [f"p0.blade.wall.01.{k + 1}"
                                             for k in range(len(pieces))]
    assert {p.piece_of for p in pieces} == {"p0.blade.wall.01"}
    ends = ordered_passes(pieces)
    assert [e.from_air for e in ends] == [False] + [True] * (len(pieces) - 1)
    assert [e.name for e in ends] == [p.path.name for p in pieces]
    # the second pass of a passage runs backwards (zig-zag): its pieces in reverse
    # order, each reversed
    ends = ordered_passes([replace(pieces[0], piece_of=None), *pieces])
    assert [e.name for e in ends[1:]] == [p.path.name + " (reversed)" for p in pieces[::-1]]
    assert [e.from_air for e in ends] == [False, False] + [True] * (len(pieces) - 1)
    assert ends[1].tip[0] == pytest.approx(pieces[-1].tip[-1])


def test_the_default_search_frees_them_and_nothing_is_left_out(
        scene: CollisionScene, kins: Kinematics) -> None:
    path = wall_pass()
    pieces, lost = finish_runs(path, TOOL, kins, scene, FinishOptions(), None)
    assert lost.size == 0 and len(pieces) == 1
    assert pieces[0].path.name == path.name and pieces[0].piece_of is None
    assert not offenders(pieces[0]).size


def test_a_pass_beside_the_wall_only_is_dropped(scene: CollisionScene,
                                                 kins: Kinematics) -> None:
    """Every posture within the wall's length: nothing clean is left; the pass is
    dropped and every point named."""
    path = wall_pass(n=5, half=WALL_HALF)
    pieces, lost = finish_runs(path, TOOL, kins, scene, FinishOptions(tilt_search_deg=10.0),
                               None)
    assert pieces == [] and lost.tolist() == list(range(5))
    assert cut_short_entry(path, lost)["dropped"]
    summary = FinishResult(pieces, TOOL, FinishOptions(), "test").summary()
    assert summary["paths"] == summary["collisions"] == summary["motion_collisions"] == 0


def test_clean_runs_keep_the_pass_plan_postures(scene: CollisionScene,
                                                kins: Kinematics) -> None:
    """The runs between the postures left out keep the postures the whole pass's plan
    gave them (``kept_run``: checked again on their own), rather than a plan of the
    shorter run, which may differ and break a rule where the whole plan did not (the
    splitter's pressure side near the tip: 7 of 55 points more left out)."""
    options = FinishOptions(tilt_search_deg=10.0)
    path = wall_pass()
    whole = finish_path(path, TOOL, kins, scene, options)
    bad = offenders(whole)
    pieces, lost = finish_runs(path, TOOL, kins, scene, options, None)
    # only the whole plan's offenders (and runs too short to cut) are left out
    assert set(bad.tolist()) <= set(lost.tolist())
    good = np.setdiff1d(np.arange(len(path)), bad)
    short = [i for i in good if not ({i - 1, i + 1} & set(good.tolist()))]
    assert sorted(set(lost.tolist()) - set(bad.tolist())) == short
    kept = np.setdiff1d(np.arange(len(path)), lost)
    assert np.concatenate([p.tip for p in pieces]) == pytest.approx(whole.tip[kept], abs=1e-12)
    assert np.concatenate([p.axis for p in pieces]) == pytest.approx(whole.axis[kept],
                                                                     abs=1e-12)
    for piece in pieces:
        assert not offenders(piece).size
        again = check_path(scene, TOOL, piece.tip, piece.axis, options)
        assert not again.interfering_points.size
        assert piece.repair is None or not piece.repair.unresolved.size


def test_a_kept_run_names_its_own_offenders(scene: CollisionScene, kins: Kinematics) -> None:
    """A run holding postures that break a rule reports them at its own indices (the
    caller then plans it on its own, ``pieces._recovered``)."""
    from cam.finishing.kept_run import kept_run

    options = FinishOptions(tilt_search_deg=10.0)
    path = wall_pass()
    whole = finish_path(path, TOOL, kins, scene, options)
    bad = offenders(whole)
    run = np.arange(int(bad[0]) - 3, int(bad[0]) + 2)
    piece = kept_run(whole, run, TOOL, scene, options, None)
    assert len(piece.path) == len(run) and not piece.path.open_end
    assert piece.path.centre == pytest.approx(path.centre[run], abs=1e-12)
    # the same checks of the same postures: the run's offenders are the pass's
    assert 3 in offenders(piece).tolist()
    assert set(run[offenders(piece)].tolist()) <= set(bad.tolist())
    assert piece.centre_deviation == pytest.approx(0.0, abs=1e-9)
