"""The scripts in docs/examples run and do what they say (issue 24), with small settings.

Each runs as a user runs it (``python docs/examples/NAME.py ...`` in a fresh process,
the project on ``PYTHONPATH``), writing into a scratch folder.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"

pytestmark = pytest.mark.slow


def _run(script: str, *args: str) -> str:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *args], env=env,
                          capture_output=True, text=True, timeout=1800, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def _json(stdout: str) -> dict[str, object]:
    data = json.loads(stdout[stdout.index("{"):])
    assert isinstance(data, dict)
    return data


def test_examples_are_all_tested() -> None:
    tested = {"design_sweep.py", "rough_post_verify.py", "apt_to_nc_verify.py",
              "build123d_keyway.py", "build_impeller.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_design_sweep(tmp_path: Path) -> None:
    _run("design_sweep.py", "--blades", "5", "7", "--fillets", "0.5", "--out", str(tmp_path))
    rows = json.loads((tmp_path / "sweep.json").read_text())
    assert [r["blades"] for r in rows] == [5, 7]
    for row in rows:
        assert (tmp_path / row["name"] / "spec.toml").is_file()
        faces = row["faces"]
        assert faces["pressure"] == faces["suction"] == row["blades"]
        assert faces["fillet"] > 0 and row["r_max_mm"] < row["d_min_mm"] / 2
    # more blades: narrower passages
    assert rows[1]["d_min_mm"] < rows[0]["d_min_mm"]


def test_rough_post_verify(tmp_path: Path) -> None:
    summary = _json(_run("rough_post_verify.py", "--passages", "1", "--resolution", "0.5",
                         "--out", str(tmp_path)))
    assert summary["toolpaths"] >= 1 and summary["poses"] > 100
    program = Path(str(summary["program"]))
    assert program.is_file() and "G1" in program.read_text()
    events = summary["events"]
    assert isinstance(events, dict)
    assert events["gouge"] == 0 and events["holder_collision"] == 0
    assert events["rapid_in_stock"] == 0
    assert float(summary["removed_volume_mm3"]) > 0  # type: ignore[arg-type]


def test_apt_to_nc_verify(tmp_path: Path) -> None:
    summary = _json(_run("apt_to_nc_verify.py", "--resolution", "0.5", "--out", str(tmp_path)))
    assert summary["operations"] == ["Isoparametric Machining.1"]
    events = summary["events"]
    assert isinstance(events, dict) and not any(events.values())
    # the passes dip at most 1 mm (z 61..62) into the 62 mm high cylinder, a 6 mm ball
    removed = float(summary["removed_volume_mm3"])  # type: ignore[arg-type]
    assert 0 < removed < math.pi * 50**2 * 1.0


def test_build123d_keyway(tmp_path: Path) -> None:
    stdout = _run("build123d_keyway.py", "--out", str(tmp_path))
    step = tmp_path / "impeller_keyway.step"
    assert step.stat().st_size > 0
    # keyway 2 x (5.5 - bore chord) x 29.5 + groove pi (38^2 - 30^2) x 1, mm^3
    bore = 4.0

    def primitive(x: float) -> float:
        return x / 2 * math.sqrt(bore**2 - x**2) + bore**2 / 2 * math.asin(x / bore)

    removed = 29.5 * (2 * 5.5 - (primitive(1.0) - primitive(-1.0))) + math.pi * (38**2 - 30**2)
    line = next(t for t in stdout.splitlines() if t.startswith("removed"))
    assert float(line.split()[1]) == pytest.approx(removed, rel=1e-5)
    assert "new (no role): 6 faces" in stdout and "pressure: 6 faces" in stdout


def test_build_impeller(tmp_path: Path) -> None:
    stdout = _run("build_impeller.py", str(tmp_path))
    assert "blades 7" in stdout
    assert (tmp_path / "variant.step").stat().st_size > 0
    assert (tmp_path / "variant.stl").stat().st_size > 0
    assert (tmp_path / "design" / "mid_camber.csv").is_file()  # the 2 deg twist
