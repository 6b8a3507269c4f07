"""The report's section builders on synthetic inputs (no chain run, no browser).

Missing inputs must be said, text from files escaped, numbers copied from the JSON.
Most tests build the page with ``render=False`` (no pyvista); one test renders.
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pytest

from cam.report import SECTION_IDS, build_report, report_html
from cam.report.figures import operation_colour
from cam.report.html import Section, format_number, page, table
from cam.report.inputs import RunFolder
from cam.report.renders import cutting_runs, decimate_runs
from cam.report.tables import flat_rows, label_of, record_tables
from cam.report.verification import summary_checks
from impeller_cam.errors import InputError
from tests.cam.report_sample import HOSTILE, run_json, write_sample


def sections_of(text: str) -> dict[str, str]:
    """Section id -> its HTML (the page has no nested sections)."""
    found = re.findall(r'<section id="([^"]+)">(.*?)</section>', text, flags=re.S)
    return dict(found)


def plain(fragment: str) -> str:
    """Text of an HTML fragment (tags dropped, entities kept)."""
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", fragment))


@pytest.fixture()
def sample(tmp_path: Path) -> Path:
    return write_sample(tmp_path / "out")


# ---------------------------------------------------------------- whole page
def test_every_section_present_with_heading(sample: Path) -> None:
    sections = sections_of(report_html(sample, render=False))
    assert tuple(sections) == SECTION_IDS
    for body in sections.values():
        assert re.match(r"\s*<h2>[^<]+</h2>", body)


def test_empty_folder_says_what_is_missing(tmp_path: Path) -> None:
    sections = sections_of(report_html(tmp_path, render=False))
    assert tuple(sections) == SECTION_IDS
    for name, body in sections.items():
        assert 'class="missing"' in body or "NOT CHECKED" in body, name
    assert "motion/motion.json is missing" in sections["servo"]
    assert "rough/rough.json is missing" in sections["umr"]
    assert "verify/finish/verify.json is missing" in sections["events"]


def test_stage_not_run_and_failed_are_named(sample: Path) -> None:
    (sample / "run.json").write_text(json.dumps(run_json({"verify": "failed",
                                                          "motion": "not run"})))
    for relative in ("verify/rough/verify.json", "verify/finish/verify.json",
                     "motion/motion.json"):
        (sample / relative).unlink()
    sections = sections_of(report_html(sample, render=False))
    assert "stage verify failed: boom &lt;bad&gt;" in sections["events"]
    assert "stage motion did not run (motion/motion.json is missing)" in sections["indexing"]
    assert "stage motion did not run" in sections["servo"]
    assert "stage verify failed" in sections["summary"]


def test_no_script_no_external_reference_and_escaped(sample: Path) -> None:
    text = report_html(sample, render=False)
    assert "<script" not in text.lower()
    assert HOSTILE not in text
    assert "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt; &amp; &lt;b&gt;bold&lt;/b&gt;" \
        in text
    assert not re.search(r'(src|href)="(https?:|//)', text)
    assert "<link" not in text


def test_images_are_png_data_uris(sample: Path) -> None:
    text = report_html(sample, render=False)
    sources = re.findall(r'<img [^>]*src="([^"]+)"', text)
    assert len(sources) >= 8  # impeller, stock, 3 deviation, 1 angle plot, 2 motion
    for src in sources:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(b"\x89PNG\r\n\x1a\n")


def test_deterministic(sample: Path) -> None:
    assert report_html(sample, render=False) == report_html(sample, render=False)


def test_build_report_writes_atomically(sample: Path) -> None:
    path = build_report(sample, render=False)
    assert path == sample / "report.html"
    assert path.read_text() == report_html(sample, render=False)
    assert not list(sample.glob(".report.html.*"))


def test_missing_folder_is_bad_input(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        build_report(tmp_path / "nowhere")


# ---------------------------------------------------------------- numbers copied
def test_umr_and_cycle_time_numbers_copied(sample: Path) -> None:
    sections = sections_of(report_html(sample, render=False))
    umr = plain(sections["umr"])
    for value in ("-91.694", "-90.729", "352.059", "45.125", "23.120"):
        assert value in umr
    cycle = plain(sections["cycle-time"])
    for value in ("23.12", "24.00", "11.91", "11.07", "868.7", "1950.2", "2818.9"):
        assert value in cycle


def test_motion_numbers_copied(sample: Path) -> None:
    sections = sections_of(report_html(sample, render=False))
    indexing = plain(sections["indexing"])
    for text in ("case I (all maxima) 0.2384", "best symmetric 0.1536",
                 "best (asymmetric allowed) (chosen) 0.1487", "7.6540", "0 .. 115 (24 values)"):
        assert text in indexing
    assert indexing.count("0.1487 0.1487") == 1  # the chosen profile is not listed twice
    servo = plain(sections["servo"])
    for text in ("nc/finish_hub.ngc 12.3 3.2 2.5 4.6 1.2 0.9 0.012 4 C",
                 "Z default: matched to X 100.00"):
        assert text in servo


def test_servo_from_a_partly_modelled_machine_is_not_shown(sample: Path) -> None:
    motion = json.loads((sample / "motion/motion.json").read_text())
    motion["servo"]["ideal_axes"] = ["Z", "A"]
    (sample / "motion/motion.json").write_text(json.dumps(motion))
    servo = sections_of(report_html(sample, render=False))["servo"]
    assert "partly modelled machine (axes Z, A followed their command)" in servo
    assert "<img" not in servo and "12.3" not in servo


def test_indexing_search_skipped(sample: Path) -> None:
    motion = json.loads((sample / "motion/motion.json").read_text())
    motion["indexing"] = {"index_moves": 6, "machine_time_s": 3.517, "optimisation": None,
                          "note": "no linear stroke: search skipped"}
    (sample / "motion/motion.json").write_text(json.dumps(motion))
    indexing = sections_of(report_html(sample, render=False))["indexing"]
    assert "No S-curve optimisation of the index moves: no linear stroke" in indexing
    assert "3.5170" in indexing and "<th>search</th>" not in indexing


def test_servo_without_servo_data(sample: Path) -> None:
    motion = json.loads((sample / "motion/motion.json").read_text())
    motion["servo"] = {"program": None, "note": "the machine file has no servo data"}
    (sample / "motion/motion.json").write_text(json.dumps(motion))
    servo = sections_of(report_html(sample, render=False))["servo"]
    assert "No servo prediction: the machine file has no servo data" in servo
    assert "<img" not in servo


def test_events_table_has_file_line_and_block(sample: Path) -> None:
    events = sections_of(report_html(sample, render=False))["events"]
    text = plain(events)
    assert "nc/finish_hub.ngc" in text
    assert "G1 X4.5 Y5 Z6 F800" in text  # line 4 of the NC file
    assert "0.046" in text and "gouge" in text
    assert "Verification of the rough programs: no events" in text


def test_no_events_stated(tmp_path: Path) -> None:
    out = write_sample(tmp_path / "out", finish_events=[])
    text = plain(sections_of(report_html(out, render=False))["events"])
    assert "finish programs: no events" in text and "rough programs: no events" in text


def test_summary_checks_pass_fail(tmp_path: Path) -> None:
    out = write_sample(tmp_path / "out", max_mm=0.41)
    checks = {name: (passed, detail) for name, passed, detail in
              summary_checks(RunFolder(out))}
    assert checks["No gouge"][0] is False
    assert "1 gouge event (rough 0, finish 1)" in checks["No gouge"][1]
    assert checks["No over-travel"][0] is True
    excess = checks["Every milled face within allowance + scallop"]
    assert excess[0] is True  # hub 0.41 <= 0.8 + 0.02
    assert "hub 0.41 mm" in excess[1] and "limit 0.820 mm" in excess[1]
    out2 = write_sample(tmp_path / "out2", finish_events=[], max_mm=1.2)
    checks2 = {name: passed for name, passed, _ in summary_checks(RunFolder(out2))}
    assert checks2["No gouge"] is True
    assert checks2["Every milled face within allowance + scallop"] is False


def test_excess_check_without_regions(tmp_path: Path) -> None:
    out = write_sample(tmp_path / "out", finish_events=[
        {"type": "excess", "line": 0, "program": "finish_hub.ngc",
         "position_mm": [0.0, 0.0, 0.0], "amount": 1.5, "message": "left"}])
    (out / "verify/regions.json").unlink()
    checks = {name: (passed, detail) for name, passed, detail in
              summary_checks(RunFolder(out))}
    passed, detail = checks["Every milled face within allowance + scallop"]
    assert passed is False and "1 excess events" in detail
    assert "verify/regions.json is missing" in detail
    deviation = sections_of(report_html(out, render=False))["deviation"]
    assert "No per-face figures: verify/regions.json is missing" in deviation


def test_region_tables(sample: Path) -> None:
    deviation = plain(sections_of(report_html(sample, render=False))["deviation"])
    assert "After finishing, per face: limit 0.820 mm = allowance 0.800" in deviation
    assert "hub_near_fillet" in deviation and "1.753" in deviation and "98.8" in deviation
    assert "hub_outside_blades lathe" in deviation and "hub_near_fillet milled" in deviation


def test_summary_verdict(tmp_path: Path) -> None:
    failing = sections_of(report_html(write_sample(tmp_path / "a"), render=False))
    assert "Verification: 1 of 6 checks failed" in failing["summary"]
    clean = write_sample(tmp_path / "b", finish_events=[])
    assert "Verification: all 6 checks passed" in \
        sections_of(report_html(clean, render=False))["summary"]
    assert "total" in plain(sections_of(report_html(clean, render=False))["summary"])


def test_summary_not_checked_without_inputs(sample: Path) -> None:
    (sample / "verify/regions.json").unlink()
    (sample / "verify/finish/verify.json").unlink()
    (sample / "verify/rough/verify.json").unlink()
    checks = {name: (passed, detail) for name, passed, detail in
              summary_checks(RunFolder(sample))}
    assert checks["No over-travel"][0] is None
    assert "verify/rough/verify.json is missing" in checks["No over-travel"][1]
    assert checks["No gouge"][0] is None
    assert checks["Every milled face within allowance + scallop"][0] is None


def test_unreadable_inputs_are_reported(sample: Path) -> None:
    (sample / "rough/rough.json").write_text("{not json")
    (sample / "geometry/impeller.png").write_bytes(b"GIF89a....")
    sections = sections_of(report_html(sample, render=False))
    assert "cannot read rough/rough.json" in sections["umr"]
    assert "geometry/impeller.png is not a PNG image" in sections["render"]


def test_angle_plots_listed_with_reversals(sample: Path) -> None:
    angles = sections_of(report_html(sample, render=False))["angles"]
    assert "p0.hub.01" in angles and "p1.hub.01" not in angles  # passage 0 plots only
    assert "7 / 0" in plain(angles)  # C reversals before / after


def test_toolpath_render(sample: Path) -> None:
    text = report_html(sample, render=True)
    sections = sections_of(text)
    paths = sections["toolpaths"]
    assert paths.count("<img ") == 4  # rough and finish, iso and top
    label, colour = operation_colour("rough", "rough_umr1")
    assert f"background:{colour}" in paths and label in paths
    assert f"background:{operation_colour('finish', 'finish_hub')[1]}" in paths
    stock = sections["stock"]
    assert "rendered from verify/finish/stock.npz" in stock and stock.count("<img ") == 2


# ---------------------------------------------------------------- small pieces
def test_cutting_runs_split_at_skipped_moves() -> None:
    tip = np.arange(24, dtype=float).reshape(8, 3)
    skip = np.array([True, False, False, True, True, False, True, False])
    runs = cutting_runs(tip, skip)
    assert [r[:, 0].tolist() for r in runs] == [[0, 3, 6], [12, 15], [18, 21]]


def test_decimate_runs_keeps_ends() -> None:
    runs = [np.zeros((101, 3)) + np.arange(101)[:, None], np.zeros((2, 3))]
    out = decimate_runs(runs, 30)
    assert sum(len(r) for r in out) <= 30 + len(runs)
    assert out[0][0, 0] == 0 and out[0][-1, 0] == 100 and len(out[1]) == 2
    assert decimate_runs(runs, 1000)[0].shape == (101, 3)


def test_format_number_and_table() -> None:
    assert format_number(1.23456) == "1.235"
    assert format_number(12) == "12"
    assert format_number(30000.0, 4) == "30000"
    assert format_number(2e-5) == "2.000e-05"
    html = table(["a", "b"], [[1.5, "<x>"], [None, 2]], digits=(1, 0))
    assert '<td class="num">1.5</td>' in html and "&lt;x&gt;" in html
    assert '<td class="none">-</td>' in html
    with pytest.raises(ValueError, match="digits"):
        table(["a"], [[1]], digits=(1, 2))


def test_labels_and_flat_rows() -> None:
    assert label_of("max_tip_deviation_mm") == "max tip deviation (mm)"
    assert label_of("amax_up_mm_s2") == "amax up (mm/s²)"
    assert label_of("kffp_best.X") == "Best K_FFP (%) / X"
    rows = flat_rows({"a_s": 1.5, "grid": {"s": {"first": 0.0, "last": 5.0, "count": 3}},
                      "flag": True, "names": ["x", "y"], "nested": [{"z": 1}]})
    assert rows == [("a (s)", 1.5), ("Search grid / s", "0 .. 5 (3 values)"), ("flag", "yes"),
                    ("names", "x, y")]


def test_record_tables_show_lists_of_objects() -> None:
    html = "".join(record_tables({"moves": [{"umr": 1, "time_s": 0.25},
                                            {"umr": 2, "extra": "<x>"}], "n": 3}))
    assert "<caption>moves</caption>" in html and "time (s)" in html
    assert "0.2500" in html and "&lt;x&gt;" in html and html.count("<tr>") == 3


def test_page_escapes_titles() -> None:
    text = page("<t>", "s&", [Section("x", "<h>", "<p>ok</p>")])
    assert "<title>&lt;t&gt;</title>" in text and '<h2>&lt;h&gt;</h2>' in text
    assert "<p>ok</p>" in text


def test_operation_colours_distinct() -> None:
    colours = {operation_colour("finish", f"finish_{op}")[1] for op in
               ("junction", "blade", "hub", "edge", "fillet")}
    colours |= {operation_colour("rough", f"rough_umr{i}")[1] for i in (1, 2, 3)}
    assert len(colours) == 8


def test_one_legend_entry_per_umr_and_no_unset_settings(sample: Path) -> None:
    # a UMR cut in two visits has two programs; the legend names the UMR once
    from postproc.apt import read_apt, write_apt

    write_apt(sample / "rough/rough_umr1_layers1-1.apt",
              read_apt(sample / "rough/rough_umr1.apt"))
    post = json.loads((sample / "nc/post.json").read_text())
    post["programs"].insert(1, {**post["programs"][0], "name": "rough_umr1_layers1-1",
                                "apt": "rough/rough_umr1_layers1-1.apt"})
    (sample / "nc/post.json").write_text(json.dumps(post))
    run = json.loads((sample / "run.json").read_text())
    run["settings"] = {"rough_tool": "ball6", "post": None, "verify_resolution_mm": 0.25}
    (sample / "run.json").write_text(json.dumps(run))
    sections = sections_of(report_html(sample, render=False))
    assert sections["toolpaths"].count("roughing UMR 1</li>") == 1
    summary = plain(sections["summary"])
    assert "rough_tool: ball6" in summary and "verify_resolution_mm: 0.25" in summary
    assert "post:" not in summary


def test_servo_on_the_part_and_in_the_air_apart(sample: Path) -> None:
    motion = json.loads((sample / "motion/motion.json").read_text())
    row = motion["servo"]["programs"][0]
    row["on_the_part"] = {"contact_blocks": 1561, "surface_max_um": 170.4,
                          "surface_p99_um": 61.4, "surface_median_um": 1.5,
                          "surface_best_kffp_max_um": 165.7, "into_part_max_um": 88.2,
                          "air_blocks": 18, "contour_air_max_um": 133.8,
                          "air_blocks_error_over_gap": 0}
    (sample / "motion/motion.json").write_text(json.dumps(motion))
    servo = plain(sections_of(report_html(sample, render=False))["servo"])
    assert f"{row['program']} 1561 170.4 61.4 1.5 165.7 88.2 18 133.8 0" in servo
    assert "Blocks on the part" in servo
