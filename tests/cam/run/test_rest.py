"""The rest operation (``cam.run.rest``): its trigger (finishing's postures the rough
stock left out, ``cam.run.rest_trigger``), its choice of points, its planner offset, and
finishing planned again only where it cut (``cam.finishing.plan_memo``)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.finishing.options import FinishOptions
from cam.finishing.plan_memo import PlanMemo
from cam.run.rest import PAD, RestTrim, rest_samples
from cam.run.rest_trigger import meets_stock, passage_of, stock_left_out
from impeller_cam.errors import InputError
from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS, SMALL_SPEC


def _path(centres: np.ndarray) -> SimpleNamespace:
    return SimpleNamespace(centre=np.asarray(centres, np.float64))


def test_rest_samples_keep_milled_samples_beyond_the_limit() -> None:
    points = np.arange(15.0).reshape(5, 3)
    signed = np.array([0.5, 2.0, 2.0, 1.5, 3.0])
    milled = np.array([True, True, False, True, True])
    out = rest_samples(points, signed, milled, 1.5)
    np.testing.assert_array_equal(out, points[[1, 4]])


def test_a_point_needs_the_rest_operation_within_reach_of_a_sample() -> None:
    trim = RestTrim(np.array([[10.0, 0.0, 0.0]]), reach=2.0, pitch=math.pi / 2, passages=4)
    centres = np.array([[8.5, 0.0, 0.0], [7.9, 0.0, 0.0], [10.0, 0.0, 1.99],
                        [10.0, 0.0, 2.01]])
    np.testing.assert_array_equal(trim.needed(centres), [True, False, True, False])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 5), st.floats(0.0, 2.0 * math.pi))
def test_a_sample_in_any_passage_marks_the_passage_0_point(k: int, angle: float) -> None:
    """A sample at the passage-0 point turned by k pitches is found (any k < passages)."""
    pitch = 2.0 * math.pi / 6
    centre = np.array([[20.0 * math.cos(angle), 20.0 * math.sin(angle), 5.0]])
    turn = k * pitch
    rot = np.array([[math.cos(turn), -math.sin(turn), 0.0],
                    [math.sin(turn), math.cos(turn), 0.0], [0.0, 0.0, 1.0]])
    sample = centre @ rot.T + [0.0, 0.0, 0.5]
    trim = RestTrim(sample, reach=1.0, pitch=pitch, passages=6)
    assert trim.needed(centre).all()
    assert not RestTrim(sample, reach=1.0, pitch=pitch, passages=k).needed(centre).any()


def test_the_kept_points_are_widened_by_pad_and_all_kept_is_none() -> None:
    x = np.arange(20.0)
    centres = np.column_stack([x, np.zeros(20), np.zeros(20)])
    trim = RestTrim(np.array([[10.0, 3.0, 0.0]]), reach=3.2, pitch=1.0, passages=1)
    mask = trim(_path(centres))  # type: ignore[arg-type]
    assert mask is not None
    need = trim.needed(centres)
    np.testing.assert_array_equal(np.flatnonzero(need), [9, 10, 11])
    np.testing.assert_array_equal(np.flatnonzero(mask), np.arange(9 - PAD, 12 + PAD))
    everywhere = RestTrim(centres, reach=0.1, pitch=1.0, passages=1)
    assert everywhere(_path(centres)) is None  # type: ignore[arg-type]
    nowhere = RestTrim(np.zeros((0, 3)), reach=1.0, pitch=1.0, passages=1)
    assert not nowhere(_path(centres)).any()  # type: ignore[arg-type, union-attr]


def test_the_allowance_and_the_threshold_are_checked() -> None:
    with pytest.raises(InputError, match="allowance_mm"):
        FinishOptions(allowance_mm=-0.1)
    with pytest.raises(InputError, match="rest_threshold_mm"):
        FinishOptions(rest_threshold_mm=0.0)
    assert FinishOptions().allowance_mm == 0.0 and FinishOptions().rest_machining


def _entry(name: str, centres: list[list[float]]) -> dict[str, object]:
    return {"path": name, "left_out": list(range(len(centres))), "centres_mm": centres}


def test_the_passage_is_read_from_the_pass_name() -> None:
    assert passage_of("p0.blade.blade0.pressure.04") == 0
    assert passage_of("p12.fillet.blade1.suction.00.te") == 12
    assert passage_of("junction") == 0


def test_only_left_out_postures_near_rest_samples_call_for_the_rest_operation() -> None:
    """A left-out posture counts when a sample beyond the limit lies within the span of
    its ball centre; the others (left out for the design or the machine) do not."""
    samples = np.array([[10.0, 0.0, 0.0]])
    cut_short = [_entry("p0.blade.blade0.pressure.04", [[10.0, 0.0, 11.9], [10.0, 0.0, 12.1]]),
                 _entry("p0.fillet.blade1.suction.00.te", [[40.0, 0.0, 0.0]])]
    found = stock_left_out(cut_short, samples, 12.0, math.pi / 3)
    assert found.points == 1 and found.left_out == 3
    assert found.passes == frozenset({"p0.blade.blade0.pressure.04"})
    np.testing.assert_allclose(found.centres, [[10.0, 0.0, 11.9]])
    none = stock_left_out(cut_short, np.zeros((0, 3)), 12.0, math.pi / 3)
    assert none.points == 0 and none.left_out == 3 and not none.passes


def test_with_causes_only_postures_that_meet_the_stock_count() -> None:
    """A posture that meets the design or the machine, or breaks a rule, in its pass's
    plan is left out for that, whatever stock lies near."""
    samples = np.array([[10.0, 0.0, 0.0]])
    entry = _entry("p0.hub.03", [[10.0, 0.0, 1.0]] * 4)
    entry["causes"] = ["stock", "hub", "machine", None]
    found = stock_left_out([entry], samples, 12.0, math.pi / 3)
    assert found.points == 1 and found.left_out == 4 and found.passes == {"p0.hub.03"}
    entry["causes"] = ["hub", None, "blade", "fillet"]
    assert stock_left_out([entry], samples, 12.0, math.pi / 3).points == 0
    assert not meets_stock([entry])  # the stock need not even be measured
    assert meets_stock([entry, _entry("p1.hub.03", [[0.0, 0.0, 0.0]])])  # no causes
    assert not meets_stock([])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 6), st.floats(0.0, 2.0 * math.pi), st.floats(5.0, 60.0))
def test_left_out_centres_are_turned_into_passage_0(k: int, angle: float,
                                                     radius: float) -> None:
    """A posture of passage k is passage 0's posture turned by k pitches: turned back,
    it lands on passage 0's centre (the rest operation is planned on passage 0)."""
    pitch = 2.0 * math.pi / 7
    centre_0 = np.array([radius * math.cos(angle), radius * math.sin(angle), 7.0])
    turn = k * pitch
    centre_k = [radius * math.cos(angle + turn), radius * math.sin(angle + turn), 7.0]
    found = stock_left_out([_entry(f"p{k}.hub.03", [centre_k])],
                           np.array([centre_k]) + [0.0, 0.0, 0.5], 1.0, pitch)
    np.testing.assert_allclose(found.centres, [centre_0], atol=1e-9)


def test_the_memo_recalls_plans_except_those_planned_anew() -> None:
    memo = PlanMemo()
    assert memo.recall("ball4", "p0.hub.01") is None
    memo.record("ball4", "p0.hub.01", "plan a")
    memo.record("ball4", "p0.hub.02", "plan b")
    assert memo.recall("ball4", "p0.hub.01") == "plan a" and memo.recalled == 1
    assert memo.recall("ball2", "p0.hub.01") is None  # another tool's pass
    again = memo.again({"p0.hub.02"})
    assert again.recall("ball4", "p0.hub.01") == "plan a"
    assert again.recall("ball4", "p0.hub.02") is None
    again.record("ball4", "p0.hub.02", "plan c")
    assert memo.plans[("ball4", "p0.hub.02")] == "plan c" and again.recalled == 1


def _lumped_stock(design: object, distance: object, folder: Path) -> tuple[Path, np.ndarray]:
    """The small design with a lump of stock 1.5-4 mm off blade 0's pressure side, 2-12
    mm up the ruling from the middle of its pass ``.01`` next to the hub: on the
    milled face below the tip (beyond the rest limit) and on over the tip, where the
    finishing tool's neck passes when its ball is on the lower passes -- what
    roughing leaves where its ball cannot follow the blade. Returns the saved stock
    and the lump's corners (8, 3)."""
    import trimesh

    from cam.finishing.options import scallop_stepover
    from cam.finishing.passes import passage_paths
    from cam.tools import resolve_tool
    from cam.verify.stock import Stock

    tool = resolve_tool(CHAIN_SETTINGS["finish_tool"])
    options = FinishOptions.from_mapping(CHAIN_SETTINGS["finish"])
    paths = passage_paths(design.surfaces, tool.radius, options.point_spacing_mm,  # type: ignore[attr-defined]
                          scallop_stepover(tool.radius, options.scallop_mm), hub=False,
                          reach=tool.flute_length - tool.radius)
    path = next(p for p in paths if p.name == "p0.blade.blade0.pressure.01")
    i = len(path.centre) // 2
    normal = path.normal[i]
    ruling = path.reference_axis[i] - (path.reference_axis[i] @ normal) * normal
    ruling /= np.linalg.norm(ruling)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = normal, ruling, np.cross(normal, ruling)
    frame[:3, 3] = path.centre[i] + (2.75 - tool.radius) * normal + 7.0 * ruling
    lump = trimesh.creation.box(extents=[2.5, 10.0, 4.0], transform=frame)
    mesh = design.mesh()  # type: ignore[attr-defined]
    both = trimesh.util.concatenate([mesh, lump])
    assert isinstance(both, trimesh.Trimesh)
    stock = Stock.from_mesh(np.asarray(both.vertices), np.asarray(both.faces), 0.5)
    return stock.save(folder / "stock.npz"), np.asarray(lump.vertices)


@pytest.mark.slow
def test_the_rest_operation_cuts_where_the_stock_left_finishing_short(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A lump of stock beyond the threshold blocks finishing's neck: finishing leaves
    postures out there; the rest operation is planned only near the lump, verified,
    and finishing planned again (those passes only) reaches the points or names them."""
    from cam.finishing.command import run_finish
    from cam.run.rest import REST_VERIFY, finish_with_rest
    from cam.run.rough_stock import RoughStock
    from cam.run.settings import RunSettings
    from cam.run.stages import Context, finish_options
    from cam.verify.deviation import DesignDistance
    from geometry.impeller import Impeller
    from postproc.apt import read_apt

    design = Impeller.from_spec(SMALL_SPEC)
    mesh = design.mesh()
    distance = DesignDistance(np.asarray(mesh.vertices, np.float64),
                              np.asarray(mesh.faces, np.int64))
    out = tmp_path / "out"
    (out / "rough").mkdir(parents=True)
    (out / "verify" / "rough").mkdir(parents=True)
    stock, lump = _lumped_stock(design, distance, out / "verify" / "rough")
    eta = 0.3
    (out / "rough" / "rough.json").write_text(json.dumps(
        {"finishing_allowance_mm": eta, "options": {"scallop_mm": 1.0}}))
    run_settings = RunSettings(rough_tool="ball6", finish_tool=CHAIN_SETTINGS["finish_tool"],
                           verify_resolution_mm=0.5,
                           finish={**CHAIN_SETTINGS["finish"], "passages": 1})
    ctx = Context(SMALL_SPEC, CHAIN_MACHINE, out, run_settings)
    runs: list[tuple[dict[str, object], PlanMemo]] = []

    def finish(stock: Path, memo: PlanMemo) -> dict[str, object]:
        document = run_finish(SMALL_SPEC, CHAIN_MACHINE, run_settings.finish_tool, out / "finish",
                              options=FinishOptions.from_mapping(finish_options(ctx)),
                              progress=False, plots=False, stock=stock, design=design,
                              design_distance=distance, memo=memo)
        runs.append((document, memo))
        return document

    final = finish_with_rest(ctx, RoughStock(stock, design, distance), finish)
    rest = json.loads((out / "rest/rest.json").read_text())
    first = runs[0][0]
    assert rest["planned"] and rest["stock_left_out_points"] > 0, (
        json.dumps(rest), [(e["path"], e["left_out"], e["causes"])
                           for e in first["cut_short"]])  # type: ignore[attr-defined]
    assert len(runs) == 2  # finishing ran again against the rest stock
    again = runs[1][1]
    # the stock left postures out only near the lump: every one the trigger took
    span = rest["span_mm"]
    for entry in first["cut_short"]:  # type: ignore[attr-defined]
        if entry["path"] in rest["stock_left_out_passes"]:
            centres = np.asarray(entry["centres_mm"])
            near = np.linalg.norm(centres[:, None] - lump[None], axis=2).min(axis=1)
            assert (near <= span + 5.0).any()
    # the rest operation cuts only near the lump (reach + PAD points + the lump's size)
    from cam.tools import resolve_tool

    radius = resolve_tool(CHAIN_SETTINGS["finish_tool"]).radius
    cuts: list[np.ndarray] = []
    for name in rest["operations"]:
        for toolpath in read_apt(out / "rest" / f"rest_{name}.apt"):
            cut = ~toolpath.link & (toolpath.feed > 0)
            cuts.append(toolpath.tip[cut] + radius * toolpath.axis[cut])
    cut_centres = np.vstack(cuts)
    middle = lump.mean(axis=0)
    bound = (rest["reach_mm"] + (PAD + 1) * CHAIN_SETTINGS["finish"]["point_spacing_mm"]
             + float(np.linalg.norm(lump - middle, axis=1).max()))
    far = np.linalg.norm(cut_centres - middle, axis=1)
    assert np.percentile(far, 95) <= bound, (np.percentile(far, 95), bound)
    assert rest["points"] < 0.25 * first["summary"]["points"]  # type: ignore[index]
    # every round of the rest operation verified clean, each on the stock before it
    verified = [REST_VERIFY, *(r["verify"] for r in rest["rounds"] if "verify" in r)]
    for folder in verified:
        counts = json.loads((out / folder / "verify.json").read_text())["event_counts"]
        for kind in ("holder_collision", "gouge", "overtravel", "rapid_in_stock"):
            assert counts[kind] == 0, (folder, kind, counts)
    # finishing against the last round's stock: only the passes the trigger named anew
    assert Path(final["stock"]["source"]) == out / verified[-1] / "stock.npz"  # type: ignore[index]
    assert rest["replanned_passes"] == len(rest["stock_left_out_passes"])
    assert again.recalled > 0 and rest["recalled_plans"] == again.recalled
    before = {e["path"]: len(e["left_out"]) for e in first["cut_short"]}  # type: ignore[attr-defined]
    after = {e["path"]: len(e["left_out"]) for e in final["cut_short"]}  # type: ignore[attr-defined]
    replanned = set(rest["stock_left_out_passes"])
    assert sum(after.get(p, 0) for p in replanned) < sum(before[p] for p in replanned)
    for name in set(before) - replanned:  # the others keep their plans
        assert after.get(name) == before[name]
    assert rest["left_out_after"]["all"] == sum(after.values())
    _taken_over_as_swept(out, run_settings.finish_tool, distance, monkeypatch)


def _taken_over_as_swept(out: Path, tool: str, distance: object,
                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The verify stage's run of the rest programs and a finish program takes the rest
    run's record over (``cam.verify.swept``): only the finish program is swept, and
    every output is the same, byte for byte, as sweeping them all."""
    import shutil

    from cam.run.rest import REST_VERIFY
    from cam.verify import command
    from cam.verify.command import VerifyOptions, run_verify
    from cam.verify.stock import Stock
    from postproc.command import post_text

    nc = out / "nc"
    nc.mkdir()
    ran = json.loads((out / REST_VERIFY / "verify.json").read_text())["programs"]
    programs = [Path(shutil.copy(out / REST_VERIFY / "nc" / p["name"], nc / p["name"]))
                for p in ran]  # in the run's order, as the post stage writes them
    assert programs and (out / REST_VERIFY / "swept.json").is_file()
    programs.append(nc / "finish_hub.ngc")
    programs[-1].write_text(post_text(out / "finish" / "finish_hub.apt", CHAIN_MACHINE))
    swept: list[str] = []
    sweep = command._sweep_program

    def counted(*args: object) -> object:
        swept.append(str(args[-1]))
        return sweep(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(command, "_sweep_program", counted)
    start = out / "verify" / "rough" / "stock.npz"
    deviations = {}
    for name, resume in (("all", None), ("resumed", out / REST_VERIFY)):
        swept.clear()
        deviations[name] = run_verify(
            programs, CHAIN_MACHINE, tool, str(start), SMALL_SPEC, 0.5, out / name,
            options=VerifyOptions(allowance=0.8, render_each_program=False), progress=False,
            design_distance=distance, initial_stock=Stock.load(start), resume_from=resume)
        assert swept == [p.name for p in (programs if resume is None else programs[-1:])]
    files = sorted(p.name for p in (out / "all").iterdir())
    assert files == sorted(p.name for p in (out / "resumed").iterdir())
    for file in files:
        assert (out / "all" / file).read_bytes() == (out / "resumed" / file).read_bytes(), file
    a, b = deviations["all"], deviations["resumed"]
    assert a is not None and b is not None
    for field in ("points", "distance", "moves", "faces"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    # a program changed since the record: everything is swept again
    programs[0].write_text(programs[0].read_text() + "\n")
    swept.clear()
    run_verify(programs, CHAIN_MACHINE, tool, str(start), SMALL_SPEC, 0.5, out / "changed",
               options=VerifyOptions(allowance=0.8, render_each_program=False),
               progress=False, design_distance=distance, initial_stock=Stock.load(start),
               resume_from=out / REST_VERIFY)
    assert swept == [p.name for p in programs]
