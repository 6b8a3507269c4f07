"""Cross-dialect verification on the small impeller's own roughing and finishing.

The chain's roughing (3+2, one UMR per passage side) and blade finishing (5-axis) of
the ``small`` fixture (``chain_small``) are posted as LinuxCNC (M428 TCP), Sinumerik
(TRAORI vectors, TRAORI rotary positions, CYCLE800 frames for the UMRs) and
Heidenhain (FUNCTION TCPM, PLANE SPATIAL for the UMRs); ``impeller-cam verify`` runs
the roughing on the spec's blank and the finishing on the stock each roughing left,
at a coarse 0.5 mm. Removed volumes agree within 0.01 % and the events (type, block)
are the same in every dialect. (The same check on the bundled APT fixture runs in the
fast tier: tests/postproc/test_post_controls_verify.py.)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam.verify.command import VerifyOptions, run_verify
from postproc.command import post_text
from postproc.machine import load_machine
from postproc.nc_reader import read_nc
from tests.cam.conftest import CHAIN_MACHINE, SMALL_SPEC

pytestmark = pytest.mark.slow  # 12 verification runs: about 30 s of a core

FORMS = {
    "linuxcnc": ("linuxcnc", "ngc", {}),
    "sinumerik_vectors": ("sinumerik", "mpf", {"orientation": "vector"}),
    "sinumerik_rotary": ("sinumerik", "mpf", {}),
    "sinumerik_cycle800": ("sinumerik", "mpf", {"frames": "cycle800"}),
    "heidenhain_tcpm": ("heidenhain", "h", {}),
    "heidenhain_plane": ("heidenhain", "h", {"frames": "plane-spatial"}),
}


@pytest.fixture(scope="module")
def verified(chain_small: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, list]:
    folder = tmp_path_factory.mktemp("controls")
    rough_apt = chain_small / "rough" / "rough.apt"
    finish_apt = chain_small / "finish" / "finish_blade.apt"
    results: dict[str, list] = {}
    for key, (post, suffix, extra) in FORMS.items():
        runs = []
        stock = str(SMALL_SPEC)
        for op, apt, tool in (("rough", rough_apt, "ball6"), ("finish", finish_apt,
                                                            "ball4_taper")):
            program = folder / f"{key}_{op}.{suffix}"
            program.write_text(post_text(apt, CHAIN_MACHINE, post=post, tcp=True,
                                         post_options=extra))
            out = folder / f"{key}_{op}"
            run_verify([program], CHAIN_MACHINE, tool, stock, None, 0.5, out,
                       options=VerifyOptions(render=False), progress=False)
            runs.append((program, json.loads((out / "verify.json").read_text())))
            stock = str(out / "stock.npz")
        results[key] = runs
    return results


def test_frames_are_written(verified) -> None:  # type: ignore[no-untyped-def]
    rough = verified["sinumerik_cycle800"][0][0].read_text()
    assert rough.count("CYCLE800(0,") >= 2
    assert verified["heidenhain_plane"][0][0].read_text().count("PLANE SPATIAL") >= 2


def test_removed_volumes_agree(verified) -> None:  # type: ignore[no-untyped-def]
    reference = [report["programs"][0]["removed_volume_mm3"]
                 for _, report in verified["linuxcnc"]]
    assert min(reference) > 100.0
    for key, runs in verified.items():
        volumes = [report["programs"][0]["removed_volume_mm3"] for _, report in runs]
        assert np.allclose(volumes, reference, rtol=1e-4, atol=0.0), (key, volumes)


def test_same_events_at_corresponding_blocks(verified) -> None:  # type: ignore[no-untyped-def]
    machine = load_machine(CHAIN_MACHINE)

    def events(runs: list) -> list[tuple[int, str, int]]:
        out = []
        for k, (program, report) in enumerate(runs):
            lines = read_nc(program, machine=machine).line
            for event in report["events"]:
                block = int(np.searchsorted(lines, event["line"]))
                assert lines[block] == event["line"]
                out.append((k, event["type"], block))
        return sorted(out)

    def split(found: list[tuple[int, str, int]]) -> tuple[list, list]:
        machine_events = [e for e in found if e[1] == "machine_collision"]
        return [e for e in found if e[1] != "machine_collision"], machine_events

    reference, reference_machine = split(events(verified["linuxcnc"]))
    # (on the chain's model-less trunnion the small chain may report no stock event:
    # then every form must report none)
    for key, runs in verified.items():
        stock_events, machine_events = split(events(runs))
        assert stock_events == reference, key
        # a machine clearance crossed between two blocks is reported at the block that
        # crosses it: the forms' block ends agree to the printed digits, so the crossing
        # may fall one block earlier or later
        assert len(machine_events) == len(reference_machine), key
        for ours, others in ((machine_events, reference_machine),
                             (reference_machine, machine_events)):
            for event in ours:
                assert any(e[0] == event[0] and abs(e[2] - event[2]) <= 1 for e in others), (
                    key, event)
