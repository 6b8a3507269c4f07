"""What the chain's finish stage gives finishing (fast, no chain)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from cam.run.settings import resolve_settings
from cam.run.stages import (
    Context,
    finish_options,
    known_collisions,
    post_stage,
    roughed_stock,
)
from impeller_cam.errors import InputError
from tests.cam.run.test_settings import MACHINE, spec_with

#: The small fixture: finishing allowance 0.3 mm, blank stock allowance 1.0 mm.
TABLE = '[machining]\nrough_tool = "ball6"\nfinish_tool = "ball4_taper"\n'


def context(tmp_path: Path, rough_scallop: float, finish: str = "") -> Context:
    spec = spec_with(tmp_path, TABLE + finish)
    out = tmp_path / "out"
    (out / "rough").mkdir(parents=True)
    (out / "rough" / "rough.json").write_text(json.dumps(
        {"finishing_allowance_mm": 0.3, "options": {"scallop_mm": rough_scallop}}))
    return Context(spec=spec, machine=MACHINE, out=out, settings=resolve_settings(spec))


def test_finishing_clears_the_allowance_plus_the_roughing_scallop(tmp_path: Path) -> None:
    ctx = context(tmp_path, 1.0)
    assert roughed_stock(ctx) == pytest.approx(0.3 + 1.0)
    options = finish_options(ctx)
    assert options["clearance_mm"] == pytest.approx(0.5 + 1.3)
    assert options["clearance_exact_mm"] == pytest.approx(3.0)


def test_the_blank_stock_over_the_tips_counts_when_it_is_larger(tmp_path: Path) -> None:
    ctx = context(tmp_path, 0.2)  # 0.3 + 0.2 < the blank's 1.0 mm over the shroud
    assert roughed_stock(ctx) == pytest.approx(1.0)
    assert finish_options(ctx)["clearance_mm"] == pytest.approx(1.5)


def test_the_spec_clearance_is_the_clearance_from_the_stock(tmp_path: Path) -> None:
    ctx = context(tmp_path, 1.0, "[machining.finish]\nclearance_mm = 2.0\n"
                                 "point_spacing_mm = 0.7\n")
    options = finish_options(ctx)
    assert options["clearance_mm"] == pytest.approx(3.3)
    assert options["clearance_exact_mm"] == pytest.approx(3.3)  # raised to it
    assert options["point_spacing_mm"] == pytest.approx(0.7)  # the others unchanged


def test_without_rough_json_the_rough_stage_is_named(tmp_path: Path) -> None:
    ctx = context(tmp_path, 1.0)
    (ctx.out / "rough" / "rough.json").unlink()
    with pytest.raises(InputError, match="run the rough stage first"):
        finish_options(ctx)


def _finish_json(ctx: Context, **changes: Any) -> None:
    """A finish.json with one clean path and one operation, ``changes`` applied."""
    path = {"name": "p0.blade.blade0.pressure.01", "collisions": 0, "motion_collisions": 0}
    rough = json.loads((ctx.out / "rough" / "rough.json").read_text())
    (ctx.out / "rough" / "rough.json").write_text(json.dumps(
        {**rough, "tool": {"name": "ball6"}, "operations": [{"apt": "rough_umr1.apt"}]}))
    document: dict[str, Any] = {
        "tool": {"name": "ball4_taper"},
        "paths": [{**path, **changes.get("path", {})}],
        "operations": {"blade": {"apt": "finish_blade.apt", "link_collisions": 0,
                                 **changes.get("operation", {})}},
        "machine_model": changes.get("machine")}
    (ctx.out / "finish").mkdir(parents=True, exist_ok=True)
    (ctx.out / "finish" / "finish.json").write_text(json.dumps(document))


@pytest.mark.parametrize(("changes", "named"), [
    ({"path": {"collisions": 2}}, "p0.blade.blade0.pressure.01: 2 postures"),
    ({"path": {"motion_collisions": 1}}, "p0.blade.blade0.pressure.01: 0 postures, 1 moves"),
    ({"operation": {"link_collisions": 3}}, "operation blade: 3 link moves"),
    ({"machine": {"operations": {"blade": {"machine_collision_moves": 4}}}},
     "operation blade: 4 moves hit the machine"),
])
def test_a_finish_program_with_a_known_collision_is_not_posted(
        tmp_path: Path, changes: dict[str, Any], named: str) -> None:
    """Issue 28: the chain stops before the post stage writes anything (exit code 2)."""
    ctx = context(tmp_path, 1.0)
    _finish_json(ctx, **changes)
    assert known_collisions(json.loads((ctx.out / "finish" / "finish.json").read_text()))
    with pytest.raises(InputError, match="still collide") as caught:
        post_stage(ctx)
    assert named in str(caught.value) and "finish.json" in str(caught.value)
    assert not (ctx.out / "nc").exists()


def test_a_clean_finish_json_has_no_known_collision(tmp_path: Path) -> None:
    ctx = context(tmp_path, 1.0)
    _finish_json(ctx, machine={"operations": {"blade": {"machine_collision_moves": 0}}})
    assert known_collisions(json.loads((ctx.out / "finish" / "finish.json").read_text())) == []
