"""The swarf operation in finishing: options, the point-milling fallback's skip, and the
checked passes on the developable fixture ``straight`` (issue 23)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cam.collision.scene import PostureReport
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.passes import passage_paths
from cam.finishing.swarf_plan import SwarfWall, covered_by, swarf_walls
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


def test_covered_blade_passes_are_skipped(straight: ImpellerSurfaces, tool: Tool,
                                          walls: list[SwarfWall]) -> None:
    """Blade passes inside the swarf band are left out, the other operations kept.

    On ``straight`` the band reaches v = 0.75 (2 mm above the hub) and the lowest blade
    pass runs higher (the junction passes finish the fillet strip), so every blade pass
    is swarf-cut; with every ruling rejected none is.
    """
    stepover = scallop_stepover(tool.radius, 0.1)
    base = passage_paths(straight, tool.radius, 1.0, stepover, blade=True, hub=False,
                         reach=tool.flute_length - tool.radius)
    blade = [p for p in base if p.operation == "blade"]
    assert blade
    skip = covered_by(walls)
    for p in blade:
        assert p.blade_v is not None and np.all(p.blade_v <= 0.75)
        assert skip(p)
    assert not any(skip(p) for p in base if p.operation != "blade")
    rejected = [SwarfWall(sw.wall, replace(sw.result, cuttable=np.zeros_like(sw.result.cuttable)),
                          sw.blade_u) for sw in walls]
    assert not any(covered_by(rejected)(p) for p in blade)


def test_rejected_rulings_are_not_covered(walls: list[SwarfWall]) -> None:
    sw = walls[0]
    rejected = replace(sw.result, cuttable=np.zeros_like(sw.result.cuttable))
    none = SwarfWall(sw.wall, rejected, sw.blade_u)
    u = np.linspace(sw.blade_u.min(), sw.blade_u.max(), 7)
    assert not none.covered(u, np.full(7, 0.3)).any()
    assert sw.covered(u, np.full(7, 0.3)).all()
    assert not sw.covered(u, np.full(7, 0.95)).any()  # below the band


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
