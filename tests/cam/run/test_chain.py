"""``impeller-cam run`` on the small fixture (session fixture ``chain_small``).

The chain runs once with coarse settings (every passage roughed and finished); these
tests read its folder: the layout of the contract, rs274 on every NC file, the
verification of the project's own programs, motion.json. Rerunning a stage and the
failure semantics run on copies of it.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cam.cli import main
from cam.run.record import STAGES
from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS, SMALL_SPEC

CONTRACT_FILES = [
    "run.json", "geometry/impeller.step", "geometry/impeller.stl", "geometry/geometry.json",
    "geometry/impeller.png", "rough/rough.json", "finish/finish.json",
    "finish/finish_junction.apt", "finish/finish_blade.apt", "finish/finish_hub.apt",
    "finish/finish_edge.apt",
    "finish/scene.stl", "nc/post.json", "verify/rough/verify.json",
    "verify/rough/report.html", "verify/rough/verify.junit.xml", "verify/rough/stock.npz",
    "verify/finish/verify.json", "verify/finish/stock.npz", "verify/regions.json",
    "motion/motion.json", "motion/contour_map.png", "motion/indexing_time_vs_s.png",
]


def load(out: Path, rel: str) -> dict:
    return json.loads((out / rel).read_text())


def copy_of(chain: Path, tmp_path: Path) -> Path:
    out = tmp_path / "out"
    shutil.copytree(chain, out)
    return out


def test_every_stage_is_recorded_and_the_contract_files_exist(chain_small: Path) -> None:
    run = load(chain_small, "run.json")
    assert [s["name"] for s in run["stages"]] == list(STAGES)
    status = {s["name"]: s for s in run["stages"]}
    for name in STAGES[:-1]:
        entry = status[name]
        assert entry["status"] == "done", entry
        assert entry["seconds"] > 0 and entry["peak_mb"] > 0 and entry["error"] is None
        assert entry["outputs"] and all((chain_small / p).is_file() for p in entry["outputs"])
    try:
        import cam.report  # noqa: F401
    except ImportError:
        assert status["report"]["status"] == "failed"
        assert "cam.report" in status["report"]["error"]
    else:
        assert status["report"]["status"] == "done"
        assert (chain_small / "report.html").is_file()
    assert run["tools"] == {"rough": "ball6", "finish": "ball4_taper"}
    assert run["settings"]["rough"] == CHAIN_SETTINGS["rough"]
    for rel in CONTRACT_FILES:
        assert (chain_small / rel).is_file(), rel
    assert not list(chain_small.rglob(".staging-*"))


def test_the_main_job_plans_no_research_baseline(chain_small: Path) -> None:
    """The five-axis baseline and Table 1 belong to ``impeller-cam rough --compare``
    and the roughing benchmark: the chain plans, times and checks the 3+2 plan only."""
    rough = load(chain_small, "rough/rough.json")
    assert rough["compare"] is False
    assert not (chain_small / "rough" / "table1.md").exists()
    for field in ("time_min", "time_limited_min", "time_breakdown", "cut_points",
                  "plan_notes", "rapids_in_stock"):
        assert set(rough[field]) == {"3axis"}, field
    assert "baseline_collisions" not in rough and "paper_table1_min" not in rough
    assert rough["time_min"]["3axis"]["1000"] > 0


def test_verify_renders_the_stock_after_the_last_program_only(chain_small: Path) -> None:
    """The report shows the stock after each run's last program; the chain does not
    render the state after each of its dozens of roughing programs."""
    for stage in ("rough", "finish"):
        # the verify stage's finish run starts with the rest operation's programs
        count = len(nc_of(chain_small, stage)) + (len(nc_of(chain_small, "rest"))
                                                  if stage == "finish" else 0)
        pictures = sorted(p.name for p in (chain_small / "verify" / stage).glob("stock_*.png"))
        assert len(pictures) == 1 and pictures[0].startswith(f"stock_{count}_"), pictures


def nc_of(out: Path, operation: str) -> list[dict]:
    return [p for p in load(out, "nc/post.json")["programs"] if p["operation"] == operation]


def test_post_json_lists_rough_then_finish_programs(chain_small: Path) -> None:
    post = load(chain_small, "nc/post.json")
    rough = load(chain_small, "rough/rough.json")
    assert post["post"] == "linuxcnc"  # the machine's dialect
    ops = [p["operation"] for p in post["programs"]]
    # the rest operation (cam.run.rest) between roughing and finishing, when planned;
    # finish: junction, blade, edge (round the leading edge), hub, then the fillet
    # pencil with the library's largest ball that fits the 1 mm fillet (ball2_taper)
    rest = load(chain_small, "rest/rest.json")
    rest_ops = rest.get("operations", []) if rest["planned"] else []
    assert ops == (["rough"] * len(rough["operations"]) + ["rest"] * len(rest_ops)
                   + ["finish"] * 5)
    assert [p["name"] for p in post["programs"] if p["operation"] == "rest"] == [
        f"rest_{op}" for op in ("junction", "blade", "hub") if op in rest_ops]
    assert [p["name"] for p in post["programs"][-5:]] == [
        "finish_junction", "finish_blade", "finish_edge", "finish_hub", "finish_fillet"]
    for program in post["programs"]:
        assert program["nc"].endswith(".ngc") and (chain_small / program["nc"]).is_file()
        assert (chain_small / program["apt"]).is_file()
        assert program["blocks"] > 10
        assert program["tool"] == ("ball6" if program["operation"] == "rough"
                                   else "ball2_taper" if program["name"] == "finish_fillet"
                                   else "ball4_taper")


def test_nc_programs_pass_rs274(chain_small: Path) -> None:
    from tests.rs274_runner import rs274_path, run_rs274

    if rs274_path() is None:
        pytest.skip("LinuxCNC's rs274 is not installed")
    for program in load(chain_small, "nc/post.json")["programs"]:
        run = run_rs274(chain_small / program["nc"])
        assert len(run.feed) >= program["blocks"] - 5


def test_verification_finds_no_gouge_and_no_overtravel(chain_small: Path) -> None:
    for kind in ("rough", "finish"):
        counts = load(chain_small, f"verify/{kind}/verify.json")["event_counts"]
        assert counts["gouge"] == 0, (kind, counts)
        assert counts["overtravel"] == 0, (kind, counts)
    assert not load(chain_small, "verify/regions.json")["finish"]["gouge"]  # machined samples


def test_finishing_shank_and_holder_clear_the_stock_roughing_left(chain_small: Path
                                                                  ) -> None:
    """Defect (85 events, up to 0.80 mm): finishing kept the shank 0.5 mm from the design
    while the inlet blade sides still carried 0.7-1.0 mm of roughing stock; the chain
    now adds that stock to the finishing clearance (0.5 + 0.3 + 1.0 mm here)."""
    finish = load(chain_small, "finish/finish.json")
    assert finish["options"]["clearance_mm"] == pytest.approx(
        0.5 + 0.3 + CHAIN_SETTINGS["rough"]["scallop_mm"])
    summary = finish["summary"]
    assert summary["collisions"] == summary["motion_collisions"] == 0
    assert finish["link_collisions"] == 0 and not summary["smaller_tool_needed"]
    assert summary["min_clearance_mm"] >= finish["options"]["clearance_mm"]
    counts = load(chain_small, "verify/finish/verify.json")["event_counts"]
    assert counts["holder_collision"] == 0 and counts["rapid_in_stock"] == 0, counts


def test_the_chain_roughs_in_depth_layers_unless_the_spec_says(chain_small: Path) -> None:
    """The chain's default ``umr_layering = "depth"`` (``stages.CHAIN_ROUGH_DEFAULTS``:
    finishing checks the stock the layers really leave); a spec or override wins."""
    from cam.run.settings import resolve_settings
    from cam.run.stages import Context, rough_options

    assert load(chain_small, "rough/rough.json")["options"]["umr_layering"] == "depth"
    ctx = Context(SMALL_SPEC, CHAIN_MACHINE, chain_small,
                  resolve_settings(SMALL_SPEC, rough={"umr_layering": "ruling"}))
    assert rough_options(ctx)["umr_layering"] == "ruling"


def test_finishing_plans_against_the_verified_rough_stock(chain_small: Path) -> None:
    """Issue 18: the finish stage verifies the rough programs first and plans against
    that stock (the one the verify stage finishes from: equal volumes); shank and
    holder keep 0.5 mm from its material beyond the 1.3 mm roughing is meant to leave,
    no path is left touching it, and the cutter's engagement is reported per path."""
    finish = load(chain_small, "finish/finish.json")
    stock = finish["stock"]
    # after the rest operation (cam.run.rest), when it was planned, the stock it left
    met = "rest" if load(chain_small, "rest/rest.json")["planned"] else "rough"
    assert stock["source"].endswith(f"verify/{met}/stock.npz")
    rough = load(chain_small, f"verify/{met}/verify.json")
    assert stock["stock_volume_mm3"] == pytest.approx(rough["remaining_volume_mm3"], abs=1e-3)
    assert stock["offset_mm"] == pytest.approx(0.3 + CHAIN_SETTINGS["rough"]["scallop_mm"])
    assert finish["options"]["stock_clearance_mm"] == pytest.approx(0.5)
    assert stock["paths_blocked_by_stock"] == []
    for entry in finish["paths"]:
        assert set(entry["stock_engagement"]) == {"max_depth_mm", "points_over"}
    assert stock["engaged_points_over"] == sum(len(e["stock_engagement"]["points_over"])
                                               for e in finish["paths"])


def test_verification_finds_no_holder_collision_and_no_rapid_in_stock(chain_small: Path
                                                                      ) -> None:
    """Roughing keeps every rapid's ball 0.25 mm clear of the stock it models
    (``cam.roughing.sweptstock``) and finishing keeps shank and holder clear of the
    stock roughing left; the verification's dexel stock agrees."""
    for kind in ("rough", "finish"):
        counts = load(chain_small, f"verify/{kind}/verify.json")["event_counts"]
        assert counts["holder_collision"] == 0 and counts["rapid_in_stock"] == 0, counts


def test_finished_blades_and_hub_mostly_within_allowance_and_scallop(chain_small: Path
                                                                     ) -> None:
    """Between the blades' edges and away from the fillets, 99 % of the blade and hub
    samples keep at most scallop + 0.05 mm (gouge tolerance) after finishing; the
    strips next to the fillets, the fillets and the edges are milled faces of their
    own, the lathe-turned faces (inlet/outlet of the hub, back, bore, rim, tips)
    are listed apart."""
    regions = load(chain_small, "verify/regions.json")
    finish = regions["finish"]
    assert finish["allowance_mm"] == pytest.approx(CHAIN_SETTINGS["finish"]["scallop_mm"])
    assert finish["limit_mm"] == pytest.approx(finish["allowance_mm"] + 0.05)
    for role in ("pressure", "suction", "hub"):
        table = finish["acceptance"][role]
        assert table["samples"] > 1000, role
        assert table["machined_share"] > 0.99, (role, table)
        assert table["p99_mm"] <= finish["limit_mm"], (role, table)
        assert table["over_limit_share"] < 0.01, (role, table)
        assert f"{role}_near_fillet" in finish["acceptance"]
    assert {"fillet", "leading_edge", "trailing_edge"} <= set(finish["acceptance"])
    assert "hub_outside_blades" in finish["lathe"] and "back" in finish["lathe"]
    assert not set(finish["lathe"]) & set(finish["acceptance"])
    # the fillet pencil (ball2_taper, R 1 = r_f) finishes the fillets and, with its
    # passes beyond the fillet and round both edges, the hub next to them (measured:
    # fillet max 0.30, hub_near_fillet 0.26 mm against 0.85), without a gouge
    for group in ("fillet", "hub_near_fillet"):
        assert finish["acceptance"][group]["within_limit"], (group, finish["acceptance"][group])
        assert finish["acceptance"][group]["machined_share"] == 1.0, group
    assert not finish["gouge"]
    assert regions["rough_allowance_mm"] == pytest.approx(
        0.3 + CHAIN_SETTINGS["rough"]["scallop_mm"])


def test_the_verdict_covers_every_milled_face(chain_small: Path) -> None:
    """Accepted only when every milled face group is within the limit, nothing is
    gouged and no stock is short; the blank contains the design (no stock_short)."""
    finish = load(chain_small, "verify/regions.json")["finish"]
    within = all(t["within_limit"] for t in finish["acceptance"].values())
    assert finish["accepted"] == (within and not finish["gouge"]
                                  and finish["stock_short_samples"] == 0)
    assert finish["failed"] == sorted(r for r, t in finish["acceptance"].items()
                                      if not t["within_limit"])
    assert finish["stock_short_samples"] == 0
    assert finish["accepted"] and finish["failed"] == [], finish["failed"]
    counts = load(chain_small, "verify/rough/verify.json")["event_counts"]
    assert counts["stock_short"] == 0


def test_motion_json(chain_small: Path) -> None:
    motion = load(chain_small, "motion/motion.json")
    post = load(chain_small, "nc/post.json")
    assert [p["nc"] for p in motion["programs"]] == [p["nc"] for p in post["programs"]]
    for program in motion["programs"]:
        assert program["cycle_time_s"] >= program["nominal_s"] > 0
    assert motion["total_s"] == pytest.approx(sum(p["cycle_time_s"]
                                                  for p in motion["programs"]))
    indexing = motion["indexing"]
    assert indexing["index_moves"] >= 6  # one UMR at least, six passages
    assert indexing["best_asymmetric_s"] <= indexing["best_symmetric_s"] \
        <= indexing["case_I_s"] + 1e-12
    assert indexing["chosen"] == "best_asymmetric" and indexing["grid"] == "coarse"
    servo = motion["servo"]
    assert servo["program"] == "all finishing programs"
    assert set(servo["axis_models"]) == {"X", "Y", "Z", "A", "C"}
    for row in servo["programs"]:
        assert set(row["kffp_best"]) == {"X", "Y", "Z", "A", "C"}
        assert row["max_contour_um"] >= row["rms_contour_um"] > 0
        assert (chain_small / "motion" / row["per_line"]).is_file()
        part = row["on_the_part"]  # the ball on the design surface, apart from air
        assert part["contact_blocks"] > 0.5 * row["blocks"]
        assert part["contact_blocks"] + part["air_blocks"] == row["blocks"]
        assert 0 <= part["into_part_max_um"] <= part["surface_max_um"] + 1e-9
    assert (chain_small / "motion" / servo["plot"]).is_file()
    assert all((chain_small / "motion" / name).is_file() for name in servo["plots"])


def test_rerun_one_stage_from_the_outputs_on_disk(chain_small: Path, tmp_path: Path) -> None:
    out = copy_of(chain_small, tmp_path)
    step = (out / "geometry/impeller.step").stat().st_mtime_ns
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--rough-tool", "ball6", "--finish-tool", "ball4_taper",
                 "--stage", "post", "--post", "fanuc"])
    assert code == 0
    post = load(out, "nc/post.json")
    assert post["post"] == "fanuc"
    assert all(p["nc"].endswith(".nc") for p in post["programs"])
    assert all((out / p["nc"]).is_file() for p in post["programs"])
    assert (out / "geometry/impeller.step").stat().st_mtime_ns == step
    stages = {s["name"]: s for s in load(out, "run.json")["stages"]}
    assert stages["post"]["status"] == "done"
    assert stages["verify"]["status"] == "done" and stages["verify"]["stale"] is True
    assert "stale" not in stages["rough"]


def test_bad_roughing_tool_fails_the_rough_stage_only(chain_small: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    """ball10 does not fit the small impeller's passages (r_max 3.1 mm): exit 2."""
    out = tmp_path / "out"
    out.mkdir()
    shutil.copytree(chain_small / "geometry", out / "geometry")
    before = {p: p.read_bytes() for p in (out / "geometry").iterdir()}
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--rough-tool", "ball10", "--finish-tool", "ball4_taper",
                 "--from", "rough"])
    assert code == 2
    err = capsys.readouterr().err
    assert "ball10" in err and "r_max" in err, err
    assert {p: p.read_bytes() for p in (out / "geometry").iterdir()} == before
    assert not (out / "rough").exists()
    stages = {s["name"]: s for s in load(out, "run.json")["stages"]}
    assert stages["rough"]["status"] == "failed" and stages["rough"]["error"]
    for name in STAGES[STAGES.index("rough") + 1:]:
        assert stages[name]["status"] == "not run"


def test_a_stage_without_its_inputs_names_the_stage_to_run(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(tmp_path),
                 "-t", "ball4_taper", "--stage", "post"])
    assert code == 2
    err = capsys.readouterr().err
    assert "rough" in err and "run the rough stage first" in err


def test_a_short_blank_stops_the_verify_stage(chain_small: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """The chain verifies its own blank before the first block: a blank 5 % too
    narrow (about 1 mm short at the rim and 0.8 mm at the trailing edges) fails the
    verify stage with exit code 2 and one message; verify/ keeps its earlier files."""
    import cam.verify.sources as sources

    out = copy_of(chain_small, tmp_path)
    before = (out / "verify" / "regions.json").read_bytes()
    real = sources.spec_blank_profile

    def narrow(spec, surfaces=None):  # type: ignore[no-untyped-def]
        return real(spec, surfaces) * [0.95, 1.0]

    monkeypatch.setattr(sources, "spec_blank_profile", narrow)
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--rough-tool", "ball6", "--finish-tool", "ball4_taper",
                 "--stage", "verify", "--resolution", "1.0"])
    assert code == 2
    assert "does not contain the design" in capsys.readouterr().err
    stages = {s["name"]: s for s in load(out, "run.json")["stages"]}
    assert stages["verify"]["status"] == "failed"
    assert "does not contain the design" in stages["verify"]["error"]
    assert (out / "verify" / "regions.json").read_bytes() == before


def test_rerun_of_verify_replaces_its_nested_folder(chain_small: Path, tmp_path: Path
                                                    ) -> None:
    out = copy_of(chain_small, tmp_path)
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--rough-tool", "ball6", "--finish-tool", "ball4_taper",
                 "--stage", "verify", "--resolution", "1.0"])
    assert code == 0
    for kind in ("rough", "finish"):
        assert load(out, f"verify/{kind}/verify.json")["resolution_mm"] == pytest.approx(1.0)
    assert load(out, "verify/regions.json")["resolution_mm"] == pytest.approx(1.0)
    assert load(out, "verify/finish/verify.json")["stock"] == str(
        out / "verify" / "rough" / "stock.npz")
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_the_verify_stage_reuses_the_finish_stage_rough_run_only_when_it_matches(
        chain_small: Path, tmp_path: Path) -> None:
    """``rough_stock.reusable_rough``: the finish stage's rough verification stands for
    the verify stage's only when it verified the very programs the post stage wrote,
    with the same tool, resolution and allowance."""
    import shutil

    from cam.run.rough_stock import reusable_rough
    from cam.run.settings import resolve_settings
    from cam.run.stages import Context

    out = tmp_path / "out"
    for relative in ("rough/rough.json", "nc/post.json", "verify/rough/verify.json",
                     "verify/rough/stock.npz"):
        (out / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(chain_small / relative, out / relative)
    programs = [p["nc"] for p in load(chain_small, "nc/post.json")["programs"]
                if p["operation"] == "rough"]
    (out / "verify/rough/nc").mkdir()
    for nc in programs:
        shutil.copy(chain_small / nc, out / nc)
        shutil.copy(chain_small / nc, out / "verify/rough/nc" / Path(nc).name)
    settings = {k: v for k, v in CHAIN_SETTINGS.items()}
    ctx = Context(SMALL_SPEC, CHAIN_MACHINE, out, resolve_settings(SMALL_SPEC, **settings))
    assert reusable_rough(ctx) == out / "verify/rough"
    other = Context(SMALL_SPEC, CHAIN_MACHINE, out, resolve_settings(
        SMALL_SPEC, **{**settings, "verify_resolution_mm": 0.5}))
    assert reusable_rough(other) is None
    with open(out / programs[0], "a") as handle:
        handle.write("(changed)\n")
    assert reusable_rough(ctx) is None


@pytest.mark.slow
def test_the_finish_stage_rough_run_keeps_the_deviation_the_verify_stage_reads(
        chain_small: Path, tmp_path: Path) -> None:
    """``verify_rough`` leaves ``verify/rough/deviation.npz``; the verify stage's design
    distance (``LabelledDesign``) reads it back for that run's stock (no query), and
    the answers are the query's."""
    import numpy as np

    from cam.run.regions import LabelledDesign
    from cam.run.rough_stock import DEVIATION, stock_deviation, verify_rough
    from cam.run.settings import resolve_settings
    from cam.run.stages import Context
    from cam.verify.deviation import load_deviation
    from cam.verify.stock import Stock

    out = tmp_path / "out"
    for relative in ("rough", "nc", "run.json"):
        source = chain_small / relative
        if source.is_dir():
            shutil.copytree(source, out / relative)
        else:
            shutil.copy(source, out / relative)
    ctx = Context(SMALL_SPEC, CHAIN_MACHINE, out, resolve_settings(SMALL_SPEC, **CHAIN_SETTINGS))
    rough = verify_rough(ctx)
    stock_path = rough.path
    saved = stock_path.parent / DEVIATION
    assert saved.is_file()
    design = LabelledDesign(SMALL_SPEC)
    stock = Stock.load(stock_path)
    points, _, moves = stock.surface_samples()
    known = load_deviation(saved, points, moves, design.distance)
    assert known is not None and known.faces is not None  # read back, not queried
    # the distance finishing is handed is the verification's design distance
    assert rough.distance.fingerprint == design.distance.fingerprint
    signed, faces = design.distance.closest(points)
    assert np.array_equal(known.distance, signed) and np.array_equal(known.faces, faces)
    again = stock_deviation(stock, design.distance, saved)
    assert np.array_equal(again.distance, signed)
