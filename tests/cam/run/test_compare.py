"""``cam.run.compare``: two run folders' verification results, quantity by quantity.

Hand-made run folders (the files' layout of docs/run.md, a few face groups) so that
every rule is checked at its boundary; the real chain's folders are compared in
``test_imported_chain.py``.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest

from cam.run.compare import FAULT_EVENTS, Tolerances, compare_runs, main, run_quantities
from impeller_cam.errors import InputError

RESOLUTION = 0.3


def face(max_mm: float, over: float = 0.1) -> dict[str, Any]:
    return {"samples": 10_000, "limit_mm": 0.55, "machined_share": 1.0, "max_mm": max_mm,
            "p99_mm": max_mm - 0.1, "median_mm": 0.2, "min_mm": 0.01, "over_limit": 1000,
            "over_limit_share": over, "within_limit": max_mm <= 0.55}


def run_files() -> dict[str, dict[str, Any]]:
    """The JSON files of a finished chain, small enough to read."""
    stages = ["geometry", "rough", "finish", "post", "verify", "motion", "report"]

    def verify(removed: float) -> dict[str, Any]:
        return {"event_counts": {**dict.fromkeys(FAULT_EVENTS, 0), "excess": 200},
                "deviation": {"max_mm": 2.0, "min_mm": -0.01, "samples": 500_000},
                "removed_volume_mm3": removed,
                "programs": [{"name": "rough.ngc", "blocks": 900,
                              "removed_volume_mm3": removed}]}

    def regions(accepted: bool) -> dict[str, Any]:
        roles = {"pressure": face(0.4), "hub": face(0.5), "fillet": face(0.9, 0.3)}
        return {"samples": 30_000, "gouge": False, "stock_short_samples": 0,
                "roles": roles, "accepted": accepted,
                "failed": [] if accepted else ["fillet"]}

    return {
        "run.json": {"stages": [{"name": n, "status": "done"} for n in stages]},
        "geometry/geometry.json": {"volume_mm3": 30_000.0, "d_min_mm": 5.0,
                                   "r_max_mm": 3.1},
        "verify/rough/verify.json": verify(20_000.0),
        "verify/finish/verify.json": verify(1_500.0),
        "verify/regions.json": {"resolution_mm": RESOLUTION, "rough": regions(False),
                                "finish": regions(False)},
        "motion/motion.json": {"programs": [{"name": "rough", "cycle_time_s": 600.0}],
                               "total_s": 600.0},
    }


def write(folder: Path, files: dict[str, dict[str, Any]]) -> Path:
    for relative, data in files.items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data))
    return folder


@pytest.fixture()
def original(tmp_path: Path) -> Path:
    return write(tmp_path / "original", run_files())


def other(tmp_path: Path, change: Any) -> Path:
    files = copy.deepcopy(run_files())
    change(files)
    return write(tmp_path / "other", files)


def test_a_folder_is_the_same_as_itself(original: Path) -> None:
    result = compare_runs(original, original)
    assert result.same and not result.differing
    assert result.length_mm == pytest.approx(0.01 + RESOLUTION)
    names = {q.name for q in result.quantities}
    assert {"finish.fillet.max_mm", "verify.finish.events.gouge", "finish.accepted",
            "motion.rough.cycle_time_s", "geometry.d_min_mm"} <= names


@pytest.mark.parametrize(("shift", "same"), [(0.30, True), (0.32, False), (-0.32, False)])
def test_face_maxima_within_geometry_plus_resolution(tmp_path: Path, original: Path,
                                                     shift: float, same: bool) -> None:
    def change(files: dict[str, Any]) -> None:
        files["verify/regions.json"]["finish"]["roles"]["hub"]["max_mm"] += shift

    result = compare_runs(original, other(tmp_path, change))
    assert result.same is same
    if not same:
        assert [q.name for q in result.differing] == ["finish.hub.max_mm"]
        assert result.differing[0].difference == pytest.approx(shift)


@pytest.mark.parametrize("kind", FAULT_EVENTS)
def test_one_more_fault_event_is_a_different_result(tmp_path: Path, original: Path,
                                                    kind: str) -> None:
    def change(files: dict[str, Any]) -> None:
        files["verify/finish/verify.json"]["event_counts"][kind] = 1

    result = compare_runs(original, other(tmp_path, change))
    assert [q.name for q in result.differing] == [f"verify.finish.events.{kind}"]


@pytest.mark.parametrize(("excess", "same"), [(210, True), (189, False)])
def test_excess_events_within_their_share(tmp_path: Path, original: Path, excess: int,
                                          same: bool) -> None:
    """One excess event per block that left material: 5 % of 200 is 10 events."""
    def change(files: dict[str, Any]) -> None:
        files["verify/rough/verify.json"]["event_counts"]["excess"] = excess

    assert compare_runs(original, other(tmp_path, change)).same is same


def test_verdicts_must_be_equal(tmp_path: Path, original: Path) -> None:
    def change(files: dict[str, Any]) -> None:
        finish = files["verify/regions.json"]["finish"]
        finish["accepted"], finish["failed"] = True, []

    differing = {q.name for q in compare_runs(original, other(tmp_path, change)).differing}
    assert differing == {"finish.accepted", "finish.failed"}


def test_volumes_and_cycle_times_relative(tmp_path: Path, original: Path) -> None:
    def change(files: dict[str, Any]) -> None:
        files["verify/rough/verify.json"]["removed_volume_mm3"] *= 1.0009
        files["geometry/geometry.json"]["volume_mm3"] *= 1.0011
        files["motion/motion.json"]["programs"][0]["cycle_time_s"] *= 1.009
        files["motion/motion.json"]["total_s"] *= 1.009
        files["verify/rough/verify.json"]["programs"][0]["blocks"] = 950  # listed only

    changed = other(tmp_path, change)
    assert [q.name for q in compare_runs(original, changed).differing] == [
        "geometry.volume_mm3"]
    assert compare_runs(original, changed, Tolerances(volume=2e-3)).same
    tight = compare_runs(original, changed, Tolerances(volume=2e-3, cycle_time=1e-3))
    assert [q.name for q in tight.differing] == ["motion.rough.cycle_time_s",
                                                 "motion.total_s"]


def test_a_stage_not_run_in_one_folder_differs(tmp_path: Path, original: Path) -> None:
    def change(files: dict[str, Any]) -> None:
        del files["motion/motion.json"]
        files["run.json"]["stages"][5]["status"] = "not run"

    result = compare_runs(original, other(tmp_path, change))
    differing = {q.name for q in result.differing}
    assert "stage.motion" in differing and "motion.total_s" in differing
    assert all(q.other is None for q in result.differing if q.name.startswith("motion."))


def test_not_a_run_folder(tmp_path: Path, original: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(InputError, match="run.json is missing"):
        run_quantities(tmp_path / "nothing")
    assert main([str(original), str(tmp_path / "nothing")]) == 2
    assert "run.json is missing" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "run.json").write_text("[1, 2]")
    with pytest.raises(InputError, match="not a JSON object"):
        run_quantities(bad)


def test_command_line_exit_codes(tmp_path: Path, original: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(original), str(original)]) == 0
    assert "the same verification result" in capsys.readouterr().out

    def change(files: dict[str, Any]) -> None:
        files["verify/rough/verify.json"]["event_counts"]["gouge"] = 3

    assert main([str(original), str(other(tmp_path, change)), "--markdown"]) == 1
    out = capsys.readouterr().out
    assert "| verify.rough.events.gouge | 0 | 3 | 3 | equal | NO |" in out
    assert "1 differ: verify.rough.events.gouge" in out


@pytest.mark.parametrize(("share", "same"), [(0.05, True), (0.07, False)])
def test_shares_allow_for_samples_that_changed_groups(tmp_path: Path, original: Path,
                                                      share: float, same: bool) -> None:
    """500 of the group's 10,000 samples moved: 0.01 + 0.05 of share allowed."""
    def change(files: dict[str, Any]) -> None:
        fillet = files["verify/regions.json"]["finish"]["roles"]["fillet"]
        fillet["samples"] += 500
        fillet["over_limit_share"] += share

    result = compare_runs(original, other(tmp_path, change))
    assert result.same is same
    q = next(q for q in result.quantities if q.name == "finish.fillet.over_limit_share")
    assert q.allowed == pytest.approx(0.06)
