"""A fillet or edge pass cut where postures break a rule (issue 28): the clean runs kept.

On the splitter fixture the suction-side fillet passes round the splitter's leading
edge break the shank clearance at postures 2-3 of 8 (ball4_taper, 2.5 mm); the
trimming cut the whole head (postures 0-4) and the fillet there kept 0.58 mm (scallop
0.4 mm). ``finish_runs`` keeps the clean head run as a piece of its own and lists the
points it leaves out. ``finish_path`` is replaced by a stand-in whose postures break
a rule where the test says (the M3 procedure itself is tested elsewhere).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from cam.finishing import pieces as pieces_mod
from cam.finishing.paths import CutterPath, subset_path
from cam.finishing.pieces import cut_short_entry, finish_runs


def _path(n: int) -> CutterPath:
    """A straight pass of ``n`` ball centres 1 mm apart along X, axes +Z."""
    centre = np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.full(n, 5.0)])
    up = np.tile([0.0, 0.0, 1.0], (n, 1))
    side = np.tile([0.0, 1.0, 0.0], (n, 1))
    return CutterPath(name="p0.fillet.splitter0.suction.01.le", operation="fillet",
                      passage=0, centre=centre, normal=side, reference_axis=up, away=side,
                      opposite_tip=centre + 10.0, curve_u=np.linspace(0.0, 0.1, n))


def _interference(x: list[float], blocked: set[float],
                  moves: frozenset[float] = frozenset()) -> SimpleNamespace:
    """The check of postures at the X positions ``x``: those at ``blocked`` interfere,
    and the motion from one at ``moves`` to the next (when the piece has a next)."""
    collides = np.array([v in blocked for v in x], dtype=bool)
    motion = np.array([v in moves for v in x[:-1]], dtype=bool)
    bad = collides.copy()
    bad[:-1] |= motion
    return SimpleNamespace(interfering_points=np.flatnonzero(bad).astype(np.intp),
                           collides=collides, motion_collides=motion)


def _stand_in(blocked: set[float], calls: list[list[float]],
              moves: frozenset[float] = frozenset()) -> Any:
    """``finish_path`` whose postures at the X positions ``blocked`` interfere (and the
    motions from those at ``moves`` to the next)."""
    def finish(path: CutterPath, *_: Any, **__: Any) -> Any:
        x = path.centre[:, 0].tolist()
        calls.append(x)
        return SimpleNamespace(path=path, trimmed=0, rule_points=np.zeros(0, dtype=np.intp),
                               interference=_interference(x, blocked, moves),
                               axis=path.reference_axis)
    return finish


def _run(monkeypatch: pytest.MonkeyPatch, n: int, blocked: set[float],
         accept: Any = None, moves: frozenset[float] = frozenset()
         ) -> tuple[list[Any], np.ndarray, list[list[float]]]:
    calls: list[list[float]] = []
    monkeypatch.setattr(pieces_mod, "finish_path", _stand_in(blocked, calls, moves))
    again = _stand_in(blocked, [], moves)
    monkeypatch.setattr(pieces_mod, "kept_run",
                        lambda result, run, *_: again(subset_path(result.path, run)))
    pieces, lost = finish_runs(_path(n), None, None, None, None, None,  # type: ignore[arg-type]
                               accept=accept)
    return pieces, lost, calls


def test_the_clean_head_before_the_offenders_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    """The splitter's case: 8 postures, 2 and 3 blocked. The trimming keeps 4-7
    (offenders in the first half move the start past them); 0-1 come back as a piece
    of their own; only 2-3 are left out, and the pieces are named in pass order."""
    pieces, lost, _ = _run(monkeypatch, 8, {2.0, 3.0})
    assert [p.path.centre[:, 0].tolist() for p in pieces] == [[0.0, 1.0], [4.0, 5.0, 6.0, 7.0]]
    assert [p.path.name for p in pieces] == ["p0.fillet.splitter0.suction.01.le.1",
                                             "p0.fillet.splitter0.suction.01.le.2"]
    assert lost.tolist() == [2, 3]
    assert pieces[0].trimmed == 2 and pieces[1].trimmed == 0


def test_a_tail_cut_at_an_interfering_motion_keeps_the_motion_s_start(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The splitter's fillet passes round the trailing edges (in-process stock by the
    neck beyond the outlet rim): posture 6 of 8 and the motions 5 -> 6 and 6 -> 7
    interfere. Posture 5 is clean and ending there drops the motion from it, so the
    pass keeps 0-5 (it ended at 4, short of the rim, before); 7 alone is no piece."""
    pieces, lost, calls = _run(monkeypatch, 8, {6.0}, moves=frozenset({5.0, 6.0}))
    assert [p.path.centre[:, 0].tolist() for p in pieces] == [[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]]
    assert lost.tolist() == [6, 7]
    assert calls[1] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    # a motion offending at the head still moves the start past the motion's start
    pieces, lost, _ = _run(monkeypatch, 8, set(), moves=frozenset({1.0}))
    assert pieces[-1].path.centre[:, 0].tolist() == [2.0, 3.0, 4.0, 5.0, 6.0, 7.0]


def test_a_clean_pass_is_one_path_with_its_own_name(monkeypatch: pytest.MonkeyPatch) -> None:
    pieces, lost, calls = _run(monkeypatch, 6, set())
    assert len(pieces) == 1 and pieces[0].path.name.endswith(".01.le")
    assert lost.size == 0 and pieces[0].trimmed == 0 and len(calls) == 1


def test_offenders_at_both_ends_and_inside(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocked 2, 8 and 12 of 14: trimming both ends would keep 3-7, less than half
    the pass, so the pass is cut at every offender into the runs between; the last
    point (13) alone is less than a piece and is left out."""
    pieces, lost, _ = _run(monkeypatch, 14, {2.0, 8.0, 12.0})
    runs = [p.path.centre[:, 0].astype(int).tolist() for p in pieces]
    assert runs == [[0, 1], [3, 4, 5, 6, 7], [9, 10, 11]]
    assert lost.tolist() == [2, 8, 12, 13]
    assert sum(len(p.path) for p in pieces) + len(lost) == 14
    assert pieces[0].trimmed == len(lost)


def test_a_recovered_piece_must_pass_the_further_test(monkeypatch: pytest.MonkeyPatch) -> None:
    """The edge passes' least lean: a head piece that fails it is left out too."""
    pieces, lost, _ = _run(monkeypatch, 8, {2.0, 3.0},
                           accept=lambda piece: piece.path.centre[0, 0] > 0.5)
    assert [p.path.centre[:, 0].tolist() for p in pieces] == [[4.0, 5.0, 6.0, 7.0]]
    assert lost.tolist() == [0, 1, 2, 3]


def test_the_cut_short_entry_names_the_points_left_out() -> None:
    path = _path(8)
    entry = cut_short_entry(path, np.array([2, 3], dtype=np.intp))
    assert entry["path"] == path.name and entry["operation"] == "fillet"
    assert entry["points"] == 8 and entry["left_out"] == [2, 3]
    assert entry["centres_mm"] == [[2.0, 0.0, 5.0], [3.0, 0.0, 5.0]]
    assert entry["curve_u"] == pytest.approx([0.1 * 2 / 7, 0.1 * 3 / 7], abs=1e-4)
    assert math.isfinite(entry["curve_u"][0])


@pytest.mark.slow
def test_the_splitter_leading_edge_fillet_is_covered() -> None:
    """Splitter fixture, passage 0, the chain's fillet tool (ball4_taper, r = r_f = 2 mm)
    and clearance (2.5 mm): the suction-side fillet passes of the splitter are clean
    (no collision, shank and holder 2.5 mm off, no reverse movement), only postures
    2-4 of the two lowest passes round the leading edge are left out, and the passes
    leave at most the scallop on that fillet (before: postures 0-4 cut, 0.58 mm)."""
    pytest.importorskip("OCP")
    from pathlib import Path

    from cam.collision import CollisionScene
    from cam.finishing.fillet_cover import material_left
    from cam.finishing.fillet_paths import fillet_passes, fillet_section, wall_interval
    from cam.finishing.fillet_plan import choose_fillet_tool, neck_lean
    from cam.finishing.options import FinishOptions
    from cam.finishing.paths import passage_walls
    from cam.finishing.scene import solid_meshes
    from geometry.impeller import Impeller
    from geometry.spec import load_spec
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    root = Path(__file__).resolve().parents[2]
    scallop = 0.4
    options = FinishOptions.from_mapping(dict(scallop_mm=scallop, point_spacing_mm=1.5,
                                              clearance_mm=2.5, clearance_exact_mm=3.0,
                                              passages=1))
    impeller = Impeller(load_spec(root / "fixtures" / "impellers" / "splitter" / "spec.toml"))
    surfaces = impeller.surfaces
    scene = CollisionScene(solid_meshes(impeller, options.tessellation_mm))
    kins = kinematics_for(load_machine(root / "fixtures" / "machines" / "trunnion-500.toml"))
    tool = choose_fillet_tool(float(surfaces.spec.fillet_radius))
    assert tool is not None and tool.name == "ball4_taper"
    passes = [p for p in fillet_passes(surfaces, tool.radius, tool.radius, scallop, 1.5,
                                       lean=neck_lean(tool, options.clearance_mm))
              if ".splitter0.suction." in p.name]
    centres = []
    lost = {}
    for path in passes:
        pieces, left_out = finish_runs(path, tool, kins, scene, options, surfaces)
        if left_out.size:
            lost[path.name] = left_out.tolist()
        for piece in pieces:
            summary = piece.summary(options)
            assert summary["collisions"] == summary["motion_collisions"] == 0, piece.path.name
            assert summary["min_clearance_mm"] >= options.clearance_mm
            assert summary["reversals_after"] == {"A": 0, "C": 0}
            assert summary["rule_violation_points"] == []
            np.testing.assert_allclose(piece.tip + tool.radius * piece.axis, piece.path.centre,
                                       atol=1e-6)
            centres.append(piece.path.centre)
    assert set(lost) <= {"p0.fillet.splitter0.suction.00.le",
                         "p0.fillet.splitter0.suction.01.le"}
    assert all(set(v) <= {2, 3, 4} for v in lost.values()), lost
    wall = next(w for pair in passage_walls(surfaces) for w in pair
                if w.label == "splitter0.suction")
    start, end = wall_interval(wall.side, 8)
    section = fillet_section(surfaces, wall, np.linspace(start, end, 800))
    angle = section.theta[:, None] * np.linspace(0.0, 1.0, 25)[None, :]
    grid = section.centre[:, None, :] + tool.radius * (
        np.cos(angle)[..., None] * section.e1[:, None, :]
        + np.sin(angle)[..., None] * section.e2[:, None, :])
    left = material_left(grid.reshape(-1, 3), centres, tool.radius)
    assert left.max() <= scallop, float(left.max())


def _stand_in_by_call(blocked: list[set[float]], calls: list[list[float]]) -> Any:
    """``finish_path`` whose k-th call's postures at the X positions ``blocked[k]``
    interfere (the last set for later calls): a piece finished again may offend
    where the whole pass's plan did not."""
    def finish(path: CutterPath, *_: Any, **__: Any) -> Any:
        x = path.centre[:, 0].tolist()
        calls.append(x)
        now = blocked[min(len(calls), len(blocked)) - 1]
        return SimpleNamespace(path=path, trimmed=0, rule_points=np.zeros(0, dtype=np.intp),
                               interference=_interference(x, now),
                               axis=path.reference_axis, piece_of=None)
    return finish


def test_a_piece_that_offends_again_is_cut_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocked 2, 8, 12 of 14 in the whole pass; finished again, the run 3-7 offends at
    5: it is cut there once more and only its clean runs are kept (issue 28: no
    piece is written with a known collision)."""
    calls: list[list[float]] = []
    monkeypatch.setattr(pieces_mod, "finish_path",
                        _stand_in_by_call([{2.0, 8.0, 12.0}, {5.0}], calls))
    # the whole plan's postures of each run break a rule checked on their own: each
    # run is planned again (kept_run falls back to finish_path)
    everywhere = _stand_in(set(map(float, range(14))), [])
    monkeypatch.setattr(pieces_mod, "kept_run",
                        lambda result, run, *_: everywhere(subset_path(result.path, run)))
    pieces, lost = finish_runs(_path(14), None, None, None, None, None)  # type: ignore[arg-type]
    runs = [p.path.centre[:, 0].astype(int).tolist() for p in pieces]
    assert runs == [[0, 1], [3, 4], [6, 7], [9, 10, 11]]
    assert lost.tolist() == [2, 5, 8, 12, 13]
    assert {p.piece_of for p in pieces} == {"p0.fillet.splitter0.suction.01.le"}


def test_a_pass_with_nothing_clean_is_dropped(monkeypatch: pytest.MonkeyPatch) -> None:
    pieces, lost, _ = _run(monkeypatch, 5, {0.0, 1.0, 2.0, 3.0, 4.0})
    assert pieces == [] and lost.tolist() == [0, 1, 2, 3, 4]
    assert cut_short_entry(_path(5), lost)["dropped"]


def test_tail_end_keeps_a_clean_posture_whose_motion_interferes() -> None:
    """``plan.tail_end`` (also ``finish_path``'s trim of an open-ended pass): a posture
    that interferes or breaks a rule ends the pass before itself, an interfering motion
    ``i -> i + 1`` only after its start ``i``."""
    from cam.finishing.plan import tail_end

    x = [float(v) for v in range(8)]
    motion = SimpleNamespace(path=_path(8), rule_points=np.zeros(0, dtype=np.intp),
                             interference=_interference(x, {6.0}, frozenset({5.0, 6.0})))
    assert tail_end(motion, np.array([5, 6])) == 6  # type: ignore[arg-type]
    ruled = SimpleNamespace(path=_path(8), rule_points=np.array([5], dtype=np.intp),
                            interference=_interference(x, {6.0}, frozenset({5.0, 6.0})))
    assert tail_end(ruled, np.array([5, 6])) == 5  # type: ignore[arg-type]
    assert tail_end(motion, np.zeros(0, dtype=np.intp)) == 8  # type: ignore[arg-type]
