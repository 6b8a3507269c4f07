"""The rest operation in rounds (issues 18 and 28: the splitter's main-blade pressure
inlet).

One rest operation is planned against the rough stock as a whole, so where the neck of
a posture meets excess stock that another pass of the same operation removes, the
posture is left out: on the splitter the rest operation left 165 postures out (145 for
the stock, near rest-stock samples beyond the limit) and finishing, against the stock
it left, still left the inlet's lowest band out (62 + 17 samples over the face limit).
``plan_rest`` therefore plans another round on the stock the round before left, where
that round left postures out for the stock, while that number falls (at most
``MAX_ROUNDS``). Here the planner and the verification are stand-ins that record what
they were asked: the rounds' order, stocks, triggers and stop rule, and the post
stage's list of programs, are checked without planning a tool path.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from cam.run import rest
from cam.run.rest import MAX_ROUNDS, plan_rest, rest_verify_folder
from cam.run.settings import RunSettings
from cam.run.stages import Context, apt_files, rest_finishes, rest_round_folder
from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS, SMALL_SPEC

PITCH = 2.0 * np.pi / 5


def _cut_short(name: str, centres: list[list[float]], cause: str | None = "stock"
               ) -> dict[str, Any]:
    return {"path": name, "left_out": list(range(len(centres))), "centres_mm": centres,
            "causes": [cause] * len(centres), "points": 20, "dropped": False,
            "curve_u": [0.0] * len(centres)}


class Stand:
    """The planner and the verification of ``plan_rest`` replaced: round ``k``'s plan
    leaves out ``left[k - 1]`` postures for the stock at the sample."""

    def __init__(self, tmp: Path, left: list[int]) -> None:
        self.tmp, self.left = tmp, left
        self.planned: list[tuple[str, str, str]] = []  # (folder, stock, prefix)
        self.verified: list[tuple[str, int]] = []  # (start stock, round)
        self.sample = np.array([[30.0, 0.0, 40.0]])

    def run_finish(self, spec: Any, machine: Any, tool: Any, out: Path, **kw: Any
                   ) -> dict[str, Any]:
        k = len(self.planned) + 1
        self.planned.append((str(out), str(kw["stock"]), kw["prefix"]))
        assert isinstance(kw["keep"], rest.RestTrim) and kw["keep"].blocked is not None
        out.mkdir(parents=True, exist_ok=True)
        left = [[30.0, 0.0, 41.0]] * self.left[k - 1]
        document = {"operations": {"blade": {"apt": f"{kw['prefix']}_blade.apt"}},
                    "tool": {"name": "ball4_taper"},
                    "cut_short": [_cut_short(f"p0.blade.w.0{k}.s1", left)] if left else [],
                    "summary": {"paths": 3, "points": 30, "left_out_points": len(left)}}
        (out / "finish.json").write_text(json.dumps(document))
        return document

    def verify(self, ctx: Context, rough: Any, document: dict[str, Any], allowance: float,
               start: Path, round_: int) -> tuple[Path, Any]:
        self.verified.append((str(start), round_))
        stock = ctx.out / rest_verify_folder(round_) / "stock.npz"
        deviation = SimpleNamespace(points=self.sample, distance=np.array([2.0]),
                                    faces=np.array([0]))
        return stock, deviation


@pytest.fixture
def context(tmp_path: Path) -> Context:
    (tmp_path / "rough").mkdir()
    (tmp_path / "rough" / "rough.json").write_text(json.dumps(
        {"finishing_allowance_mm": 0.5, "options": {"scallop_mm": 1.0}}))
    settings = RunSettings(rough_tool="ball6", finish_tool=CHAIN_SETTINGS["finish_tool"],
                           verify_resolution_mm=0.5, finish={})
    return Context(SMALL_SPEC, CHAIN_MACHINE, tmp_path, settings)


def _planned(context: Context, monkeypatch: pytest.MonkeyPatch, left: list[int]
             ) -> tuple[Stand, rest.RestPlan, dict[str, Any]]:
    stand = Stand(context.out, left)
    import cam.finishing.command as command

    monkeypatch.setattr(command, "run_finish", stand.run_finish)
    monkeypatch.setattr(rest, "_verify_rest", stand.verify)
    monkeypatch.setattr(rest, "_rough_samples", lambda *a: stand.sample)
    monkeypatch.setattr(rest, "_milled", lambda ctx, rough, points, *a: np.ones(len(points), bool))
    monkeypatch.setattr(rest, "rest_options", lambda ctx: {"allowance_mm": 0.5,
                                                           "scallop_mm": 1.0})
    spec = SimpleNamespace(pitch=PITCH, blades=5)
    rough = SimpleNamespace(path=context.out / "verify/rough/stock.npz",
                            design=SimpleNamespace(surfaces=SimpleNamespace(spec=spec)),
                            distance=None)
    finished = {"cut_short": [_cut_short("p0.blade.w.03", [[30.0, 0.0, 42.0]] * 6)]}
    plan = plan_rest(context, rough, finished)  # type: ignore[arg-type]
    record = json.loads((context.out / "rest" / "rest.json").read_text())
    return stand, plan, record


def test_a_round_that_leaves_postures_out_for_the_stock_is_followed_by_another(
        context: Context, monkeypatch: pytest.MonkeyPatch) -> None:
    stand, plan, record = _planned(context, monkeypatch, [4, 1, 0])
    # round 1 on the rough stock, round 2 on the stock round 1 left, round 3 on round 2's
    assert [p[2] for p in stand.planned] == ["rest", "rest2", "rest3"]
    assert stand.planned[0][1].endswith("verify/rough/stock.npz")
    assert stand.planned[1][1].endswith("verify/rest/stock.npz")
    assert stand.planned[2][1].endswith("verify/rest/round2/stock.npz")
    assert [Path(p[0]).relative_to(context.out).as_posix() for p in stand.planned] == [
        "rest", "rest/round2", "rest/round3"]
    assert [r for _, r in stand.verified] == [1, 2, 3]
    # finishing plans again the passes of its own postures, on the last round's stock
    assert plan.stock == context.out / "verify/rest/round3/stock.npz"
    assert plan.replan == frozenset({"p0.blade.w.03"})
    assert [r["stock_left_out_points"] for r in record["rounds"]] == [4, 1]
    assert record["rounds"][-1]["verify"] == "verify/rest/round3"
    assert MAX_ROUNDS == 3


def test_the_rounds_stop_when_none_is_left_out_or_no_fewer(
        context: Context, monkeypatch: pytest.MonkeyPatch) -> None:
    stand, plan, record = _planned(context, monkeypatch, [0])
    assert len(stand.planned) == 1 and record["rounds"] == []
    assert plan.stock == context.out / "verify/rest/stock.npz"


def test_a_round_leaving_as_many_out_as_the_trigger_ends_them(
        context: Context, monkeypatch: pytest.MonkeyPatch) -> None:
    # the first round leaves all 6 out again: no progress, no second round
    stand, plan, record = _planned(context, monkeypatch, [6, 6])
    assert len(stand.planned) == 1
    assert record["rounds"] == [{"round": 2, "stock_left_out_points": 6}]
    assert plan.stock == context.out / "verify/rest/stock.npz"


def test_the_post_stage_lists_every_round_in_order(tmp_path: Path) -> None:
    settings = RunSettings(rough_tool="ball6", finish_tool="ball4_taper",
                           verify_resolution_mm=0.5, finish={})
    ctx = Context(SMALL_SPEC, CHAIN_MACHINE, tmp_path, settings)
    for folder, document in (
            ("rough", {"tool": {"name": "ball6"}, "operations": [{"apt": "rough.apt"}]}),
            ("finish", {"tool": {"name": "ball4_taper"},
                        "operations": {"blade": {"apt": "finish_blade.apt"}}}),
            (rest_round_folder(1), {"tool": {"name": "ball4_taper"},
                                    "operations": {"hub": {"apt": "rest_hub.apt"},
                                                   "blade": {"apt": "rest_blade.apt"}}}),
            (rest_round_folder(2), {"tool": {"name": "ball4_taper"},
                                    "operations": {"blade": {"apt": "rest2_blade.apt"}}})):
        (tmp_path / folder).mkdir(parents=True, exist_ok=True)
        name = "rough.json" if folder == "rough" else "finish.json"
        (tmp_path / folder / name).write_text(json.dumps(document))
    assert [f for f, _ in rest_finishes(ctx)] == ["rest", "rest/round2"]
    assert [(op, apt) for op, apt, _ in apt_files(ctx)] == [
        ("rough", "rough/rough.apt"), ("rest", "rest/rest_blade.apt"),
        ("rest", "rest/rest_hub.apt"), ("rest", "rest/round2/rest2_blade.apt"),
        ("finish", "finish/finish_blade.apt")]
