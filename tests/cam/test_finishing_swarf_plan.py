"""The swarf operation in finishing: options, the point-milling fallback's skip, and the
checked passes on the developable fixture ``straight`` (issue 23)."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cam.collision.scene import PostureReport
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.passes import passage_paths
from cam.finishing.swarf_plan import SwarfWall, swarf_walls
from cam.tools import Tool, load_tool_library
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def straight() -> ImpellerSurfaces:
    return build_surfaces(load_spec(ROOT / "fixtures" / "impellers" / "straight" / "spec.toml"))


@pytest.fixture(scope="module")
def tool() -> Tool:
    return load_tool_library(ROOT / "fixtures" / "tools" / "library.toml")["ball4_taper"]


@pytest.fixture(scope="module")
def walls(straight: ImpellerSurfaces, tool: Tool) -> list[SwarfWall]:
    return swarf_walls(straight, tool, FinishOptions())


@pytest.mark.parametrize(("field", "value"), [("blade_strategy", "flank"),
                                              ("swarf_overcut_mm", -0.01),
                                              ("swarf_undercut_mm", math.nan),
                                              ("swarf_ruling_step_mm", 0.0)])
def test_bad_swarf_options_name_the_field(field: str, value: object) -> None:
    with pytest.raises(InputError) as error:
        FinishOptions.from_mapping({field: value})
    assert error.value.field == field


def test_swarf_walls_of_the_developable_fixture(walls: list[SwarfWall]) -> None:
    assert [sw.wall.label for sw in walls] == ["blade0.pressure", "blade1.suction"]
    for sw in walls:
        assert sw.result.cuttable.all()
        assert sw.result.area_share == pytest.approx(0.75, abs=1e-3)
        # the rulings' blade u covers the side between the edge caps, increasing or not
        assert np.all(np.diff(sw.blade_u) != 0)


def _middle_cut(sw: SwarfWall) -> SwarfWall:
    """The wall with only its middle half of rulings swarf-cut."""
    n = len(sw.blade_u)
    cut = np.zeros(n, dtype=bool)
    cut[n // 4: 3 * n // 4] = True
    return SwarfWall(sw.wall, replace(sw.result, cuttable=cut), sw.blade_u)


def _arc(centre: np.ndarray) -> np.ndarray:
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(centre, axis=0), axis=1))]


@pytest.mark.parametrize("middle", [False, True])
def test_point_passes_are_cut_to_what_swarf_leaves(straight: ImpellerSurfaces, tool: Tool,
                                                   walls: list[SwarfWall],
                                                   middle: bool) -> None:
    """Blade passes keep what the swarf band leaves plus the overlap, nothing deeper.

    A point is left out exactly when it lies ``overlap`` (a stepover) inside a run's
    band and farther than ``end_overlap`` along its pass from any point that does
    not (the point passes enter the band by the overlap only); and every sample of the wall between
    the passes' lowest and highest v is either inside the band or within half a
    stepover (plus the point spacing) of a kept pass's foot. Other operations are
    kept whole.
    """
    from cam.finishing.pieces import kept_pieces
    from cam.finishing.swarf_plan import point_passes_left

    stepover = scallop_stepover(tool.radius, 0.1)
    spacing, end = 1.0, stepover + 1.0
    base = passage_paths(straight, tool.radius, spacing, stepover, blade=True, hub=False,
                         reach=tool.flute_length - tool.radius)
    used = [_middle_cut(sw) if middle else sw for sw in walls]
    keep = point_passes_left(used, stepover, end)
    assert all(keep(p) is None for p in base if p.operation != "blade")
    left_out = 0
    for sw in used:
        blade = [p for p in base if p.operation == "blade" and p.wall is not None
                 and p.wall.label == sw.wall.label]
        assert blade
        feet = []
        for p in blade:
            assert p.wall is not None and p.blade_v is not None
            u = p.wall.own_u(p.curve_u)
            found = keep(p)
            mask = np.ones(len(p), dtype=bool) if found is None else found
            deep = sw.inside(u, p.blade_v, stepover)
            assert np.all(mask | deep)  # left out: at least the overlap inside the band
            if deep.all():
                assert not mask.any()
            else:  # kept: within the overlap along the pass of a point not that deep
                arc = _arc(p.centre)
                reach = np.abs(arc[:, None] - arc[None, ~deep]).min(axis=1)
                np.testing.assert_array_equal(mask, reach <= end)
            left_out += int((~mask).sum())
            for piece in kept_pieces(p, mask):
                assert piece.blade_v is not None
                feet.append(p.wall.blade.side(p.wall.own_u(piece.curve_u),
                                              piece.blade_v, p.wall.side))
        v_lo = min(float(p.blade_v.min()) for p in blade if p.blade_v is not None)
        v_hi = max(float(p.blade_v.max()) for p in blade if p.blade_v is not None)
        gu, gv = np.meshgrid(np.linspace(0.0, 1.0, 61), np.linspace(v_lo, v_hi, 41))
        gu, gv = gu.ravel(), gv.ravel()
        open_ = ~sw.inside(gu, gv, 0.0)
        if middle:
            assert open_.any()
        if open_.any():
            kept_feet = np.vstack(feet)
            samples = sw.wall.blade.side(gu[open_], gv[open_], sw.wall.side)
            gap = np.linalg.norm(samples[:, None, :] - kept_feet[None, :, :], axis=2)
            assert gap.min(axis=1).max() <= 0.5 * stepover + spacing
    assert left_out > 0


def test_kept_pieces_split_a_pass_into_runs(straight: ImpellerSurfaces, tool: Tool) -> None:
    from cam.finishing.pieces import kept_pieces

    base = passage_paths(straight, tool.radius, 1.0, scallop_stepover(tool.radius, 0.1),
                         blade=True, hub=False, reach=tool.flute_length - tool.radius)
    path = next(p for p in base if p.operation == "blade")
    n = len(path)
    whole = kept_pieces(path, np.ones(n, dtype=bool))
    assert len(whole) == 1 and whole[0] is path
    assert kept_pieces(path, np.zeros(n, dtype=bool)) == []
    mask = np.zeros(n, dtype=bool)
    mask[:5] = True
    mask[n - 1] = True  # a lone point takes its neighbour
    pieces = kept_pieces(path, mask)
    assert [p.name for p in pieces] == [f"{path.name}.s1", f"{path.name}.s2"]
    assert len(pieces[0]) == 5 and len(pieces[1]) == 2
    np.testing.assert_array_equal(pieces[0].centre, path.centre[:5])
    np.testing.assert_array_equal(pieces[1].centre, path.centre[n - 2:])


def _is_piece(name: str) -> bool:
    """A kept piece of a pass (``<pass>.s<k>``)."""
    return re.search(r"\.s\d+$", name) is not None


def test_trimmed_pieces_are_ordered_region_by_region(straight: ImpellerSurfaces, tool: Tool,
                                                     walls: list[SwarfWall]) -> None:
    """With the middle half of the rulings swarf-cut, each wall's blade passes are
    machined whole (or spanning) first, then the pieces before the swarf pass, then
    those after it; junction passes keep their place; every kept point is planned."""
    from cam.finishing.pieces import trimmed_passes
    from cam.finishing.swarf_plan import point_passes_left

    stepover = scallop_stepover(tool.radius, 0.1)
    base = passage_paths(straight, tool.radius, 1.0, stepover, blade=True, hub=False,
                         reach=tool.flute_length - tool.radius)
    trim = point_passes_left([_middle_cut(sw) for sw in walls], stepover, stepover + 1.0)
    paths, counts = trimmed_passes(base, trim)
    assert [p.name for p in paths if p.operation != "blade"] == [
        p.name for p in base if p.operation != "blade"]
    assert counts["passes_cut"] > 0
    assert counts["blade_points_kept"] == sum(len(p) for p in paths if p.operation == "blade")
    for sw in walls:
        mine = [p for p in paths if p.operation == "blade" and p.wall is not None
                and p.wall.label == sw.wall.label]
        regions = [trim.region(p) if _is_piece(p.name) else -1 for p in mine]
        assert regions == sorted(regions)
        assert {0, 1} <= set(regions)
        for p in mine:
            if _is_piece(p.name) and trim.region(p) >= 0:  # a piece beside the swarf pass
                u = p.wall.own_u(p.curve_u) if p.wall is not None else None
                assert u is not None
                order = np.sort(sw.blade_u)
                middle = 0.5 * (order[len(order) // 4] + order[3 * len(order) // 4 - 1])
                assert (u.max() < middle) == (trim.region(p) == 0)


def test_inside_counts_only_between_a_runs_end_rulings(walls: list[SwarfWall]) -> None:
    sw = walls[0]
    rejected = replace(sw.result, cuttable=np.zeros_like(sw.result.cuttable))
    none = SwarfWall(sw.wall, rejected, sw.blade_u)
    u = np.linspace(sw.blade_u.min(), sw.blade_u.max(), 7)
    assert not none.inside(u, np.full(7, 0.3)).any()
    assert sw.inside(u, np.full(7, 0.3)).all()
    assert not sw.inside(u, np.full(7, 0.95)).any()  # below the band
    # the depth above the band bottom (v 0.75) along the ruling
    length = np.linalg.norm(sw.wall.blade.side(u, 0.0, sw.wall.side)
                            - sw.wall.blade.side(u, 1.0, sw.wall.side), axis=1)
    depth = (0.75 - 0.70) * length
    assert sw.inside(u, np.full(7, 0.70), 0.95 * float(depth.min())).all()
    assert not sw.inside(u, np.full(7, 0.70), 1.05 * float(depth.max())).any()
    half = _middle_cut(sw)
    order = np.sort(sw.blade_u)
    n = len(order)
    mid = order[n // 4: 3 * n // 4]
    assert half.inside(mid, np.full(len(mid), 0.3)).all()
    assert not half.inside(order[:n // 4], np.full(n // 4, 0.3)).any()


@pytest.mark.slow
def test_finish_run_writes_checked_swarf_passes(tmp_path: Path) -> None:
    """``run_finish`` with ``blade_strategy = "swarf"`` on ``straight`` (passage 0, the
    closed-form surfaces as the collision scene): one flank pass per wall, no blade
    ball passes, no collision, no A/C reversal, linked without collisions."""
    from cam.finishing.command import run_finish

    doc = run_finish(ROOT / "fixtures" / "impellers" / "straight" / "spec.toml",
                     ROOT / "fixtures" / "machines" / "trunnion-500.toml", "ball4_taper",
                     tmp_path / "out", scene="surfaces", plots=False, progress=False,
                     machine_obstacle=False, blade_strategy="swarf", passages=1,
                     edge_passes=False, hub_passes=False, scallop_mm=0.1,
                     point_spacing_mm=1.0)
    ops = doc["operations"]
    assert set(ops) == {"junction", "swarf"}
    assert ops["swarf"]["paths"] == 2 and ops["swarf"]["link_collisions"] == 0
    assert (tmp_path / "out" / "finish_swarf.apt").is_file()
    swarf = doc["swarf"]
    assert swarf["passes"] == 2 and swarf["collisions"] == 0
    assert swarf["reversals_A"] == 0 and swarf["reversals_C"] == 0
    assert swarf["blade_area_share"] == pytest.approx(0.75, abs=1e-3)
    for wall in swarf["walls"]:
        assert wall["swept_overcut_mm"] <= 0.01 and wall["swept_undercut_mm"] <= 0.03
    entries = [p for p in doc["paths"] if p["operation"] == "swarf"]
    assert all(p["collisions"] == 0 and p["motion_collisions"] == 0 for p in entries)


@pytest.mark.slow
def test_swarf_or_point_run_machines_only_what_swarf_leaves(tmp_path: Path) -> None:
    """``blade_strategy = "swarf_or_point"`` on ``straight`` (passage 0, surface scene):
    the blade passes are cut to the strip below the swarf band (plus the overlap), their
    pieces machined as one pass each, with no collision."""
    from cam.finishing.command import run_finish

    doc = run_finish(ROOT / "fixtures" / "impellers" / "straight" / "spec.toml",
                     ROOT / "fixtures" / "machines" / "trunnion-500.toml", "ball4_taper",
                     tmp_path / "out", scene="surfaces", plots=False, progress=False,
                     machine_obstacle=False, blade_strategy="swarf_or_point", passages=1,
                     edge_passes=False, hub_passes=False, scallop_mm=0.1,
                     point_spacing_mm=1.0)
    kept = doc["swarf"]["point_passes"]
    assert 0 < kept["blade_points_kept"] < kept["blade_points"]
    assert kept["passes_cut"] > 0
    blade = [p for p in doc["paths"] if p["operation"] == "blade"]
    assert sum(p["points"] for p in blade) <= kept["blade_points_kept"]
    assert all(p["collisions"] == 0 and p["motion_collisions"] == 0 for p in blade)
    assert doc["operations"]["swarf"]["paths"] == 2
    assert doc["link_collisions"] == 0


class _WallAhead:
    """A stand-in collision scene: every posture whose tip lies beyond ``x_max`` (and
    every motion reaching one) collides; the rest are clear by 5 mm."""

    def __init__(self, x_max: float) -> None:
        self.x_max = x_max

    def check_postures(self, tool: Tool, tip: np.ndarray, axis: np.ndarray,
                       **_: object) -> PostureReport:
        hit = tip[:, 0] > self.x_max
        return PostureReport(hit, np.where(hit, 1, -1).astype(np.int8),
                             ["wall" if h else None for h in hit], np.where(hit, 0.0, 5.0))

    def check_motion(self, tool: Tool, tip: np.ndarray, axis: np.ndarray,
                     **_: object) -> PostureReport:
        hit = (tip[:-1, 0] > self.x_max) | (tip[1:, 0] > self.x_max)
        return PostureReport(hit, np.where(hit, 1, -1).astype(np.int8),
                             ["wall" if h else None for h in hit], np.where(hit, 0.0, 5.0))


def test_colliding_swarf_postures_are_dropped(straight: ImpellerSurfaces, tool: Tool,
                                              walls: list[SwarfWall]) -> None:
    """Postures that collide leave the swarf cut (and so go to point milling)."""
    from cam.finishing.swarf_plan import plan_swarf
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml"))
    x_max = 25.0
    result = plan_swarf(straight, tool, kins, _WallAhead(x_max),  # type: ignore[arg-type]
                        FinishOptions(passages=1), scene_source="test", walls=walls)
    assert result.paths
    for path in result.paths:
        assert np.all(path.tip[:, 0] <= x_max)
        assert not path.interference.collides.any()
        assert not path.interference.motion_collides.any()
    checked = result.extra["swarf_walls"]
    dropped = result.extra["swarf_dropped"]
    for before, after in zip(walls, checked, strict=True):
        gone = before.result.cuttable & ~after.result.cuttable
        assert gone.sum() == dropped[before.wall.label] > 0
        # beyond the wall, or the last one before it (its motion reaches the wall)
        assert np.sum(before.result.postures.tips[gone, 0] <= x_max) <= 1
        assert after.result.area_share < before.result.area_share
    assert result.extra["swarf"]["collisions"] == 0
