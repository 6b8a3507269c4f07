"""A real third-party 5-axis program: LinuxCNC's impeller demo (TCP, G93, AC table).

fixtures/nc/thirdparty/README.md names its source and licence; the blank and the tool
are our assumptions (the program names neither).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam.verify.command import VerifyOptions, run_verify
from cam.verify.stock import Stock
from postproc.nc_reader import read_nc

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "fixtures" / "nc" / "thirdparty"
#: LinuxCNC's own demo program, read from the installed Debian package linuxcnc-uspace
#: (GPL-2.0-or-later, so we do not ship a copy; .ci/run installs the package).
PROGRAM = Path(
    "/usr/share/doc/linuxcnc/examples/sample-configs/sim/axis/vismach/5axis/"
    "table-rotary-tilting/demos/impeller-7bl-xyzac.ngc"
)
pytestmark = pytest.mark.skipif(
    not PROGRAM.is_file(), reason="LinuxCNC's demo program is not installed (apt linuxcnc-uspace)"
)
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "out"
    run_verify([PROGRAM], MACHINE, f"{FOLDER / 'tools.toml'}:ball4_long",
               str(FOLDER / "impeller-7bl-blank.stl"), None, 0.5, out,
               options=VerifyOptions(render=True), progress=False)
    return out


def test_program_is_tcp_inverse_time_ac() -> None:
    program = read_nc(PROGRAM)
    assert program.tcp.all()
    feeds = program.motion == 1
    assert np.all(program.feed_mode[feeds] == 93)
    assert np.ptp(program.joints[:, 3]) > np.radians(60)  # A tilts
    assert np.ptp(program.joints[:, 4]) > np.radians(360)  # C turns more than once


@pytest.mark.slow
def test_runs_to_the_end(demo: Path) -> None:
    data = json.loads((demo / "verify.json").read_text())
    program = read_nc(PROGRAM)
    assert data["programs"][0]["blocks"] == len(program)
    assert data["event_counts"]["overtravel"] == 0
    assert data["event_counts"]["holder_collision"] == 0
    # G93: every feed block lasts 1/F min; the demo runs about 20 minutes
    assert 15 * 60 < data["cycle_time_s"] < 25 * 60
    assert 0.1 < data["removed_volume_mm3"] / data["initial_volume_mm3"] < 0.3


@pytest.mark.slow
def test_renders_a_seven_blade_part(demo: Path) -> None:
    stock = Stock.load(demo / "stock.npz")
    grid = stock.grids[2]
    # height of the material along a circle of radius 30 mm, from the Z dexels
    angle = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    x, y = 30 * np.cos(angle), 30 * np.sin(angle)
    i = np.floor((x - grid.origin[0]) / grid.pitch).astype(int)
    j = np.floor((y - grid.origin[1]) / grid.pitch).astype(int)
    rays = i * grid.shape[1] + j
    top = np.array([grid.hi[grid.start[r] + grid.count[r] - 1] if grid.count[r] else -6.0
                    for r in rays])
    spectrum = np.abs(np.fft.rfft(top - top.mean()))
    assert int(np.argmax(spectrum[1:30])) + 1 == 7  # seven passages around the part
    pngs = list(demo.glob("stock_*.png"))
    assert pngs and all(p.stat().st_size > 20_000 for p in pngs)
