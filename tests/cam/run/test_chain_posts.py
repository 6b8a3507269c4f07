"""The chain posts in every control's words: ``impeller-cam run --post --post-option --tcp``.

The small chain's programs are re-posted by ``--stage post`` as LinuxCNC TCP (M428) and
as Sinumerik TRAORI with tool-direction vectors (its 3+2 roughing as CYCLE800 frames)
and re-verified by ``--stage verify``: the removed volume of every program agrees
within 0.01 % and the same kinds of events are found. (The chain's own joint-mode
programs differ from any TCP form by the chordal tolerance of the rotary
linearisation: 0.07 % of the finish programs' removed volume at 0.3 mm.) Bad dialect
options are refused before anything is written.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cam.cli import main
from tests.cam.conftest import CHAIN_MACHINE, SMALL_SPEC

TOOLS = ["--rough-tool", "ball6", "--finish-tool", "ball4_taper"]


def _verify(out: Path, run: str) -> dict:
    return json.loads((out / "verify" / run / "verify.json").read_text())


def _repost_and_verify(chain: Path, out: Path, words: list[str]) -> dict[str, dict]:
    shutil.copytree(chain, out)
    settings = json.loads((chain / "run.json").read_text())["settings"]
    base = ["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out), *TOOLS,
            "--resolution", str(settings["verify_resolution_mm"])]
    assert main([*base, "--stage", "post", "--tcp", *words]) == 0
    assert main([*base, "--stage", "verify"]) == 0
    return {run: _verify(out, run) for run in ("rough", "finish")}


@pytest.mark.slow
def test_the_chain_reposted_for_sinumerik_verifies_alike(chain_small: Path,
                                                         tmp_path: Path) -> None:
    linuxcnc = _repost_and_verify(chain_small, tmp_path / "linuxcnc", ["--post", "linuxcnc"])
    sinumerik = _repost_and_verify(chain_small, tmp_path / "sinumerik", [
        "--post", "sinumerik", "--post-option", "orientation=vector",
        "--post-option", "frames=cycle800"])
    post = json.loads((tmp_path / "sinumerik/nc/post.json").read_text())
    assert post["post"] == "sinumerik"
    rough = (tmp_path / "sinumerik" / post["programs"][0]["nc"]).read_text()
    assert "CYCLE800(" in rough
    finish = (tmp_path / "sinumerik" / post["programs"][-1]["nc"]).read_text()
    assert "TRAORI" in finish and "A3=" in finish
    for run in ("rough", "finish"):
        ours, theirs = linuxcnc[run], sinumerik[run]
        volumes = [(a["removed_volume_mm3"], b["removed_volume_mm3"])
                   for a, b in zip(ours["programs"], theirs["programs"], strict=True)]
        assert all(a > 0 for a, _ in volumes)
        for a, b in volumes:
            assert abs(a - b) <= 1e-4 * a, (run, a, b)
        kinds = [sorted({e["type"] for e in report["events"]}) for report in (ours, theirs)]
        assert kinds[0] == kinds[1], (run, kinds)


@pytest.mark.parametrize(("words", "expected"), [
    (["--post-option", "orientation=vector"], "orientation"),
    (["--post-option", "orientatoin=vector", "--tcp"], "orientation"),
    (["--post-option", "frames=cycle801", "--tcp"], "cycle800"),
])
def test_bad_dialect_options_are_refused_before_anything_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], words: list[str],
        expected: str) -> None:
    out = tmp_path / "out"
    code = main(["run", str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o", str(out), *TOOLS,
                 "--post", "sinumerik", *words])
    assert code == 2
    assert expected in capsys.readouterr().err
    assert not out.exists()
