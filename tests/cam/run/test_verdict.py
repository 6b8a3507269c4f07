"""The chain's verdict (cam/run/verdict.py): unsafe programs end `impeller-cam run` with
exit code 1 and say what was found; faces over their limit only warn."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer

from cam.cli import _report_verdict
from cam.run.verdict import FAULT_EVENTS, chain_verdict


def _write(out: Path, rough: dict[str, int], finish: dict[str, int],
           failed: list[str]) -> None:
    for kind, counts in (("rough", rough), ("finish", finish)):
        (out / "verify" / kind).mkdir(parents=True)
        (out / "verify" / kind / "verify.json").write_text(
            json.dumps({"event_counts": {"excess": 12, **counts}}))
    (out / "verify" / "regions.json").write_text(json.dumps(
        {"finish": {"failed": failed, "limit_mm": 0.45, "accepted": not failed}}))


def test_a_clean_folder_is_safe(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _write(tmp_path, {k: 0 for k in FAULT_EVENTS}, {"gouge": 0}, [])
    verdict = chain_verdict(tmp_path)
    assert verdict.safe and verdict.faults == [] and verdict.shortfalls == []
    _report_verdict(tmp_path)  # no exit
    assert capsys.readouterr().err == ""


def test_faults_end_the_run_with_exit_code_1(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    # the splitter chain of 2026-11-27: the rough program met the machine and the stock
    _write(tmp_path, {"holder_collision": 324, "machine_collision": 322, "rapid_in_stock": 23},
           {"gouge": 16}, ["fillet", "leading_edge"])
    verdict = chain_verdict(tmp_path)
    assert not verdict.safe
    assert len(verdict.faults) == 2
    assert "324 holder collision" in verdict.faults[0] and "rough" in verdict.faults[0]
    assert "16 gouge" in verdict.faults[1]
    with pytest.raises(typer.Exit) as ended:
        _report_verdict(tmp_path)
    assert ended.value.exit_code == 1
    err = capsys.readouterr().err
    assert "warning: milled faces over the 0.450 mm limit: fillet, leading_edge" in err
    assert "do not run these NC programs" in err


def test_faces_over_the_limit_only_warn(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    _write(tmp_path, {}, {}, ["hub"])
    _report_verdict(tmp_path)
    assert capsys.readouterr().err.startswith("warning: milled faces over")


def test_a_folder_without_verification_says_nothing(tmp_path: Path) -> None:
    verdict = chain_verdict(tmp_path)
    assert verdict.safe and verdict.shortfalls == []
