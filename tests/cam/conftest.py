"""Shared fixtures of the cam tests.

``chain_small``: the whole ``impeller-cam run`` chain on the ``small`` fixture with
coarse settings, once per test run (shared by the xdist workers; about 2 minutes on
one core); returns the output folder. It runs on ``CHAIN_MACHINE``: trunnion-500's
kinematics, limits and servo data without its ``[model]`` tables. With the machine
model the small part cannot be finished on that machine with the library's short
tools (ball6 110 mm, ball4_taper 125 mm gauge length: at A -82 to -96 deg the 500 mm
head meets the platter and the shank the mandrel nut): the finish stage refuses it
before planning (``cam.finishing.machine_reach``, tested in
``tests/cam/test_machine_reach.py``), and the report tests need every stage done.
The machine model's planning and verification on the small chain are tested on
xyzac-trt, where the part fits (``tests/cam/run/test_machine_chain.py``). Other tests (the report)
read its files; they must not modify them. When ``cam.report`` is not in this build the report stage
fails (as it should) and the fixture still returns the folder with every other stage
done. ``finishing_setup``: the machine obstacle and passage paths of a spec on
trunnion-500 at the chain's coarse finishing (the machine reach and bounds tests).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from cam.run.warm import without_model

ROOT = Path(__file__).resolve().parents[2]
SMALL_SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


CHAIN_MACHINE = without_model(TRUNNION)
#: Coarse settings of the chain test: every passage roughed and finished.
CHAIN_SETTINGS: dict[str, Any] = {
    "rough_tool": "ball6",
    "finish_tool": "ball4_taper",
    "rough": {"scallop_mm": 1.0, "step_along_mm": 2.0},
    "finish": {"scallop_mm": 0.8, "point_spacing_mm": 1.5},
    "verify_resolution_mm": 0.3,
    "tessellation_mm": 0.05,
}
#: The same, one passage roughed and finished.
ONE_PASSAGE_SETTINGS: dict[str, Any] = {
    **CHAIN_SETTINGS,
    "rough": {**CHAIN_SETTINGS["rough"], "passages": 1},
    "finish": {**CHAIN_SETTINGS["finish"], "passages": 1},
}


def finishing_setup(spec: Path, tool_name: str) -> dict[str, Any]:
    """The machine obstacle and the passage-0 paths of a spec on trunnion-500, at the
    chain test's coarse finishing (``CHAIN_SETTINGS["finish"]``).

    Returns
    -------
    dict
        ``options`` (``FinishOptions``), ``tool``, ``obstacle`` (the finishing's
        machine obstacle), ``paths`` (``passage_paths``) and ``kins``.
    """
    from cam.collision import CollisionScene
    from cam.finishing.command import _machine_obstacle
    from cam.finishing.options import FinishOptions, scallop_stepover
    from cam.finishing.passes import passage_paths
    from cam.finishing.scene import surface_meshes
    from cam.tools import resolve_tool
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    options = FinishOptions.from_mapping({**FinishOptions().as_dict(),
                                          **CHAIN_SETTINGS["finish"]})
    machine = load_machine(TRUNNION)
    kins = kinematics_for(machine)
    tool = resolve_tool(tool_name)
    surfaces = build_surfaces(load_spec(spec))
    obstacle = _machine_obstacle(machine.model, kins,
                                 CollisionScene(surface_meshes(surfaces, 1.0)), None, spec)
    paths = passage_paths(surfaces, tool.radius, options.point_spacing_mm,
                          scallop_stepover(tool.radius, options.scallop_mm),
                          blade=options.blade_passes, hub=options.hub_passes,
                          reach=max(tool.flute_length - tool.radius, 0.0),
                          chordal=options.chordal_tolerance_mm)
    return {"options": options, "tool": tool, "obstacle": obstacle, "paths": paths,
            "kins": kins}


@pytest.fixture(scope="session")
def chain_small(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> Path:
    """Output folder of the whole chain on the small fixture, built once per test run:
    pytest-xdist workers share it (the first builds it under a lock, the others wait
    and read it)."""
    import fcntl

    from cam.run import run_chain

    root = tmp_path_factory.getbasetemp()
    if worker_id != "master":  # the workers' base folders share a parent
        root = root.parent
    out = root / "chain_small" / "small"
    done = root / "chain_small" / "done"
    with open(root / "chain_small.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not done.exists():
                try:
                    run_chain(SMALL_SPEC, CHAIN_MACHINE, out, progress=False,
                              **CHAIN_SETTINGS)
                except RuntimeError as error:
                    if "cam.report" not in str(error):
                        raise
                done.write_text("built\n")
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
    return out
