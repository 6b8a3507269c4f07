"""The sweep's parts: --vary parsing, cross product and Latin hypercube, largest balls,
the table, and a design-only sweep with invalid variants (blades touching)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.cli import main
from cam.run.sweep_figures import largest_balls
from cam.run.sweep_params import parse_vary, variants
from cam.run.sweep_table import columns, csv_text, row
from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml
from tests.cam.conftest import CHAIN_MACHINE, ROOT

SMALL_DESIGN = ROOT / "fixtures" / "impellers" / "small" / "design.toml"


@pytest.fixture(scope="module")
def design() -> dict:
    return load_toml(SMALL_DESIGN, "design")


def test_lists_ranges_and_types(design: dict) -> None:
    blades = parse_vary("blades=7,9,11", design)
    assert (blades.path, blades.values, blades.integer) == ("impeller.blades", (7, 9, 11), True)
    theta = parse_vary("camber.shroud.theta_deg[1]=-34:-42:4", design)
    assert theta.steps == ("camber", "shroud", "theta_deg", 1)
    assert theta.values == pytest.approx((-34.0, -34 - 8 / 3, -34 - 16 / 3, -42.0), abs=1e-6)
    assert theta.span == (-34.0, -42.0) and not theta.integer
    assert parse_vary("blade.thickness_mm=2", design).values == (2.0,)
    assert parse_vary("blade.leading_edge=round,cut", design).values == ("round", "cut")
    assert parse_vary("meridional.hub[1][0]=13,14", design).steps == (
        "meridional", "hub", 1, 0)
    assert parse_vary("impeller.blades=5:9:3", design).values == (5, 7, 9)


@pytest.mark.parametrize("argument", [
    "blades", "=7", "blades=", "blade.thick_mm=2", "camber.shroud.theta_deg[7]=1",
    "camber.shroud=1", "blades=1:2:0", "blades=a,b", "blade.thickness_mm=1,,2",
    "camber..shroud=1",
])
def test_bad_vary_is_input_error(design: dict, argument: str) -> None:
    with pytest.raises(InputError) as error:
        parse_vary(argument, design)
    assert error.value.field == "--vary"


def test_cross_product_order_and_names(design: dict) -> None:
    params = [parse_vary("blades=6,7", design), parse_vary("blade.thickness_mm=1.2,1.4,1.6",
                                                           design)]
    found = variants(design, params, "small")
    assert [v.name for v in found] == [f"small_{i:03d}" for i in range(6)]
    assert [tuple(v.parameters.values()) for v in found] == [
        (6, 1.2), (6, 1.4), (6, 1.6), (7, 1.2), (7, 1.4), (7, 1.6)]
    assert found[4].design["impeller"] == {"name": "small_004", "blades": 7}
    assert found[4].design["blade"]["thickness_mm"] == 1.4
    assert design["impeller"]["blades"] == 6  # the base is left as it was
    with pytest.raises(InputError):
        variants(design, [params[0], params[0]], "small")


@settings(max_examples=30, deadline=None)
@given(samples=st.integers(1, 40), seed=st.integers(0, 2**32 - 1))
def test_latin_hypercube_uses_each_stratum_once(samples: int, seed: int) -> None:
    design = load_toml(SMALL_DESIGN, "design")
    angle = parse_vary("camber.shroud.theta_deg[1]=-30:-20:3", design)
    edge = parse_vary("blade.leading_edge=round,cut", design)
    found = variants(design, [angle, edge], "s", samples=samples, seed=seed)
    assert len(found) == samples
    x = [v.parameters[angle.path] for v in found]
    strata = sorted(min(int((xi + 30.0) / 10.0 * samples), samples - 1) for xi in x)
    assert strata == list(range(samples))  # 6 decimals kept: no stratum edge crossed
    assert all(-30.0 <= xi <= -20.0 for xi in x)
    edges = [v.parameters[edge.path] for v in found]
    assert abs(edges.count("round") - edges.count("cut")) <= 1
    again = variants(design, [angle, edge], "s", samples=samples, seed=seed)
    assert [v.parameters for v in again] == [v.parameters for v in found]


def test_largest_balls_of_the_bundled_library() -> None:
    # bundled balls: ball10 r5, ball6_taper r3, ball4_taper r2, ball6 r3
    figures = {"d_min_mm": 8.0, "r_max_mm": (8.0 - 2 * 0.3) / 2.4,
               "protection_factor_k": 1.2, "fillet_radius_mm": 1.0}
    balls = largest_balls(figures)
    assert balls["rough"] == {"name": "ball6_taper", "radius_mm": 3.0}  # 3 <= 3.083
    assert balls["finish"] == {"name": "ball6_taper", "radius_mm": 3.0}  # 3 <= 8 / 2.4
    figures.update(d_min_mm=6.0, r_max_mm=(6.0 - 0.6) / 2.4)
    assert largest_balls(figures)["rough"]["radius_mm"] == 2.0  # 2.25 mm allowed
    assert largest_balls(figures)["finish"]["radius_mm"] == 2.0  # 2.5 mm allowed
    figures.update(fillet_radius_mm=2.6)  # no ball both >= r_f and <= 2.5
    assert largest_balls(figures)["finish"] == {"name": None, "radius_mm": None}


def test_row_and_csv_take_the_variant_json_numbers() -> None:
    variant = {"name": "v_000", "status": "failed", "stage": "rough", "error": "a, b",
               "parameters": {"impeller.blades": 7},
               "figures": {"design": {"blades": 7, "d_min_mm": 1 / 3, "r_max_mm": -0.1},
                           "rough": None, "verify": {"rough_accepted": True}}}
    names = columns(["impeller.blades"])
    r = row(variant, ["impeller.blades"])
    assert r["d_min_mm"] == 1 / 3 and r["rough_cycle_s"] is None and r["rough_accepted"]
    parsed = next(csv.DictReader(csv_text([r], names).splitlines()))
    assert float(parsed["d_min_mm"]) == 1 / 3  # shortest round-trip text
    assert parsed["error"] == "a, b" and parsed["rough_cycle_s"] == ""
    assert parsed["rough_accepted"] == "true" and parsed["impeller.blades"] == "7"


def test_bad_vary_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code = main(["sweep", str(SMALL_DESIGN), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--vary", "blade.thick_mm=1,2"])
    assert code == 2 and not out.exists()


def test_invalid_variants_are_rows(tmp_path: Path) -> None:
    """Design stage only (seconds): 40 blades touch, 6 do not; exit code 3."""
    out = tmp_path / "out"
    code = main(["sweep", str(SMALL_DESIGN), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "--vary", "blades=6,40", "--stages", "design", "--workers", "1"])
    assert code == 3
    with open(out / "sweep.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["variant"], r["status"]) for r in rows] == [("small_000", "done"),
                                                          ("small_001", "invalid")]
    assert "touch" in rows[1]["error"] and rows[1]["stage"] == "design"
    assert rows[1]["d_min_mm"] == ""
    for r in rows:  # every variant folder is whole; no staging folder left
        variant = json.loads((out / r["variant"] / "variant.json").read_text())
        assert variant["status"] == r["status"] and variant["error"] == (r["error"] or None)
        assert (out / r["variant"] / "design.toml").is_file()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    done = json.loads((out / "small_000" / "variant.json").read_text())
    assert math.isclose(float(rows[0]["d_min_mm"]), done["figures"]["design"]["d_min_mm"],
                        rel_tol=0, abs_tol=0)
    assert (out / "small_000" / "spec" / "spec.toml").is_file()
    summary = json.loads((out / "sweep.json").read_text())
    assert (summary["done"], summary["invalid"], summary["failed"]) == (1, 1, 0)
    page = (out / "sweep.html").read_text()
    assert page.count("<svg") == 2 and "sortBy" in page and "small_001" in page
    for reference in ('src="http', "src='http", 'href="http', "url(http", "<script src"):
        assert reference not in page  # nothing is loaded at view time


def test_parquet_holds_the_csv_rows(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    from cam.run.sweep_table import write_csv, write_parquet

    rows = [{"variant": "a", "status": "done", "n": 3, "x": 0.1, "ok": True, "t": None},
            {"variant": "b", "status": "invalid", "n": None, "x": 2, "ok": None, "t": None}]
    names = list(rows[0])
    assert write_parquet(tmp_path / "t.parquet", rows, names) is None
    write_csv(tmp_path / "t.csv", rows, names)
    table = pq.read_table(tmp_path / "t.parquet").to_pylist()
    assert table == [{**rows[0]}, {**rows[1], "x": 2.0}]  # one type per column
    with open(tmp_path / "t.csv", newline="") as handle:
        text = list(csv.DictReader(handle))
    assert [float(r["x"]) for r in text] == [r["x"] for r in table]


def test_a_shipped_library_names_every_tool(tmp_path: Path) -> None:
    from cam.run.sweep_task import _run_settings, chain_stages

    job = {"design": {"machining": {"rough_tool": "ball6", "finish_tool": "ball4_taper"}},
           "settings": {"finish_tool": "ball6_taper", "verify_resolution_mm": 0.3}}
    library = tmp_path / "tools.toml"
    assert _run_settings(job, None) == job["settings"]
    assert _run_settings(job, library) == {
        "rough_tool": f"{library}:ball6", "finish_tool": f"{library}:ball6_taper",
        "verify_resolution_mm": 0.3}
    job["settings"] = {"tool": "ball10"}
    assert _run_settings(job, library) == {"rough_tool": f"{library}:ball10",
                                           "finish_tool": f"{library}:ball10"}
    assert chain_stages("design") == [] and chain_stages("rough") == ["geometry", "rough"]
    assert chain_stages("all")[-1] == "report"
    with pytest.raises(InputError):
        chain_stages("post")


def test_task_carries_its_inputs_and_the_client_writes_whole_folders(
        design: dict, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from cam.run.sweep import write_variant
    from cam.run.sweep_task import variant_task

    monkeypatch.chdir(tmp_path)  # the task uses no path of the client's
    found = variants(design, [parse_vary("blades=6,40", design)], "small")
    job = {"name": found[0].name, "parameters": found[0].parameters,
           "design": found[0].design, "stages": "design", "settings": {},
           "machine": {"name": "m.toml", "text": CHAIN_MACHINE.read_text()},
           "library": None, "files": "json"}
    result = variant_task(job)
    assert result["status"] == "done" and sorted(tmp_path.iterdir()) == []
    assert sorted(result["files"]) == ["design.toml", "spec/figures.json",
                                       "spec/hub_camber.csv", "spec/shroud_camber.csv",
                                       "spec/spec.toml"]
    assert result["figures"]["design"]["blades"] == 6 and result["figures"]["rough"] is None
    bad = variant_task({**job, "name": found[1].name, "design": found[1].design})
    assert bad["status"] == "invalid" and "touch" in bad["error"] and bad["figures"] is None
    out = tmp_path / "out"
    record = write_variant(out, result, found[0].design)
    assert json.loads((out / "small_000" / "variant.json").read_text()) == record
    assert (out / "small_000" / "spec" / "spec.toml").read_bytes() == \
        result["files"]["spec/spec.toml"]
    with pytest.raises(ValueError):  # nothing half-written: no folder at all
        write_variant(out, {**bad, "files": {"../x": b""}}, found[1].design)
    assert sorted(p.name for p in out.iterdir()) == ["small_000"]
