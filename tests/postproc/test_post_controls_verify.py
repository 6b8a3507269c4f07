"""Cross-dialect verification: the same roughing and finishing in every control's words.

The fixture's 3+2 roughing and 5-axis finishing are posted (each operation its own
program) as LinuxCNC (M428 TCP), Sinumerik (TRAORI with vectors, TRAORI with rotary
positions, CYCLE800 frames for the 3+2 UMRs) and Heidenhain (FUNCTION TCPM, PLANE
SPATIAL for the UMRs), and ``impeller-cam verify`` runs each pair on the same stock
at a coarse resolution. The removed volumes agree within 0.01 % and every program
reports the same events (type) at the corresponding blocks. The programs are posted
for a copy of the machine whose Z travel is longer than the verifying machine's, so
the safe retracts over-travel there: over-travel is reported alike in every dialect.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam.verify.command import VerifyOptions, run_verify
from postproc.apt import read_apt, write_apt
from postproc.command import post_text
from postproc.machine import load_machine
from postproc.nc_reader import read_nc
from tests.postproc.golden.cases import APT, SIM

FORMS = {
    "linuxcnc": ("linuxcnc", "ngc", {}),
    "sinumerik_vectors": ("sinumerik", "mpf", {"orientation": "vector"}),
    "sinumerik_rotary": ("sinumerik", "mpf", {}),
    "sinumerik_cycle800": ("sinumerik", "mpf", {"frames": "cycle800"}),
    "heidenhain_tcpm": ("heidenhain", "h", {}),
    "heidenhain_plane": ("heidenhain", "h", {"frames": "plane-spatial"}),
}


@pytest.fixture(scope="module")
def verified(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[list[Path], dict]]:
    folder = tmp_path_factory.mktemp("cross")
    rough, finish = read_apt(APT)
    write_apt(folder / "rough.apt", [rough])
    write_apt(folder / "finish.apt", [finish])
    tall = folder / "tall.toml"  # Z up to 150: retracts beyond the sim's +120
    tall.write_text(SIM.read_text().replace("[axes.Z]\nmin = -120.0\nmax = 120.0",
                                            "[axes.Z]\nmin = -120.0\nmax = 150.0"))
    assert load_machine(tall).axes["Z"].maximum == 150.0
    results = {}
    for key, (post, suffix, extra) in FORMS.items():
        programs = []
        for op in ("rough", "finish"):
            path = folder / f"{key}_{op}.{suffix}"
            path.write_text(post_text(folder / f"{op}.apt", tall, post=post, tcp=True,
                                      post_options=extra))
            programs.append(path)
        out = folder / f"out_{key}"
        run_verify(programs, SIM, "ball6", "cylinder:70,30", None, 0.5, out,
                   options=VerifyOptions(render=False), progress=False)
        results[key] = (programs, json.loads((out / "verify.json").read_text()))
    return results


def _block_events(programs: list[Path], report: dict) -> list[tuple[int, str, int]]:
    """(program index, event type, block index) of every event."""
    names = [p.name for p in programs]
    blocks = {p.name: read_nc(p, machine=load_machine(SIM)).line for p in programs}
    out = []
    for event in report["events"]:
        lines = blocks[event["program"]]
        block = int(np.searchsorted(lines, event["line"]))
        assert lines[block] == event["line"]
        out.append((names.index(event["program"]), event["type"], block))
    return sorted(out)


def test_removed_volumes_agree_within_a_hundredth_of_a_percent(verified) -> None:  # type: ignore[no-untyped-def]
    volumes = {key: [p["removed_volume_mm3"] for p in report["programs"]]
               for key, (_, report) in verified.items()}
    reference = np.array(volumes["linuxcnc"])
    assert np.all(reference > 1000.0)  # both programs cut
    for key, volume in volumes.items():
        assert np.all(np.abs(np.array(volume) - reference) <= 1e-4 * reference), (key, volume)


def test_same_events_at_corresponding_blocks(verified) -> None:  # type: ignore[no-untyped-def]
    events = {key: _block_events(programs, report)
              for key, (programs, report) in verified.items()}
    reference = events["linuxcnc"]
    types = {kind for _, kind, _ in reference}
    assert {"rapid_in_stock", "overtravel"} <= types, types
    for key, found in events.items():
        assert found == reference, key
