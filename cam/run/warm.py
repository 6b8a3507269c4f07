"""Compile the chain's numba kernels ahead of a run, on a spare core.

The kernels are ``numba.njit(cache=True)``: a process compiles a kernel at its first
call unless ``__pycache__`` holds it already. On a fresh clone the main job would
compile the finish, verify and motion stages' kernels when it reaches them (tens of
seconds of one core each), while during the geometry and rough stages, which run on
one core, the second core is idle. ``scripts/demo`` starts this module in the
background (``nice``) beside the chain: it runs the small fixture's chain, one passage
at coarse settings, through every stage that calls kernels, into a temporary folder,
so that the later stages of the real run find their kernels compiled. The test
script does the same beside mypy (``tests/warm_kernels.py``).

The chain runs on the machine without its ``[model]`` (``without_model``); two steps
then reach the kernels it does not: the finish stage on the machine with its model
(its reach check compiles the model's clearance bounds, ``cam.verify.machine_bounds``,
whether or not the part clears the model: the small part is refused on trunnion-500
before planning, exit 2, which is expected here), and the growth of a dexel pool
(``cam.verify.dexel``'s compaction, run when a sweep overflows its pool).

Usage: ``python -m cam.run.warm [MACHINE.toml]`` (default trunnion-500); prints the
seconds it took, or why it did nothing.
"""

from __future__ import annotations

import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["SMALL_SPEC", "STAGES", "WARM_SETTINGS", "warm", "warm_dexel_growth",
           "warm_machine_model", "without_model"]

ROOT = Path(__file__).resolve().parents[2]
#: The smallest bundled design (a checkout's fixtures; absent from a wheel install).
SMALL_SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
#: The machine warmed with when none is given.
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
#: The stages whose code calls numba kernels (the report only reads their outputs).
STAGES = ("geometry", "rough", "finish", "post", "verify", "motion")
#: Coarse settings, one passage roughed and finished (the chain test's).
WARM_SETTINGS: dict[str, Any] = {
    "rough_tool": "ball6",
    "finish_tool": "ball4_taper",
    "rough": {"scallop_mm": 1.0, "step_along_mm": 2.0, "passages": 1},
    "finish": {"scallop_mm": 0.8, "point_spacing_mm": 1.5, "passages": 1},
    "verify_resolution_mm": 0.3,
    "tessellation_mm": 0.05,
}


def without_model(machine: Path) -> Path:
    """A copy of a machine file without its ``[model]`` tables (the last ones in the
    file), written once into the temp folder (the same bytes from every process).

    The small fixture at coarse settings roughs on trunnion-500's kinematics but not
    past its machine model (no orientation of the inlet UMR keeps the head clear of
    the table), so the warm-up and the chain tests run without the model.
    """
    from impeller_cam.atomic import write_text_atomic

    lines = machine.read_text().splitlines(keepends=True)
    cut = next((i for i, line in enumerate(lines)
                if line.startswith(("[model", "[[model"))), len(lines))
    rest = [line for line in lines[cut:] if line.startswith("[")
            and not line.startswith(("[model", "[[model"))]
    if rest:
        raise ValueError(f"{machine}: tables after [model]: {rest}")
    folder = Path(tempfile.gettempdir()) / "impeller-cam-tests"
    folder.mkdir(exist_ok=True)
    copy = folder / f"{machine.stem}-without-model.toml"
    text = "".join(lines[:cut])
    if not copy.is_file() or copy.read_text() != text:
        write_text_atomic(copy, text)
    return copy


def warm(out: Path, machine: Path = TRUNNION, spec: Path = SMALL_SPEC) -> None:
    """Run the warm-up chain into ``out`` (a folder that need not exist).

    Parameters
    ----------
    out : Path
        Output folder of the warm-up chain (its files are of no use afterwards).
    machine : Path
        Machine file (its kinematics; run without its ``[model]``: ``without_model``).
    spec : Path
        Impeller spec to run (the small fixture).
    """
    from cam.run import run_chain

    bare = without_model(machine)
    for stage in STAGES:
        run_chain(spec, bare, out, only=stage, progress=False, **WARM_SETTINGS)
    if bare.read_text() != machine.read_text():
        warm_machine_model(out, machine, spec)
    warm_dexel_growth()


def warm_machine_model(out: Path, machine: Path, spec: Path = SMALL_SPEC) -> None:
    """The finish stage of the warm-up chain in ``out`` again, on ``machine`` with its
    ``[model]``: its reach check compiles the model's clearance bounds. A refusal (bad
    input, exit 2: the part cannot clear the model) is expected and ignored."""
    from cam.run import run_chain
    from impeller_cam.errors import InputError

    try:
        run_chain(spec, machine, out, only="finish", progress=False, **WARM_SETTINGS)
    except InputError:
        pass


def warm_dexel_growth() -> Any:
    """Grow a one-interval dexel grid: compiles the pool's compaction (a sweep runs it
    only when its pool overflows). Returns the grid (``DexelGrid``: a 1 x 1 mm cell
    holding material from 0 to 1 mm)."""
    import numpy as np

    from cam.verify.dexel import DexelGrid

    grid = DexelGrid.from_intervals(2, np.zeros(2), (1, 1), 1.0, np.zeros(1, np.int64),
                                    np.zeros(1), np.ones(1))
    grid.grow()
    return grid


def main(argv: list[str] | None = None) -> int:
    """``python -m cam.run.warm [MACHINE.toml]``."""
    args = sys.argv[1:] if argv is None else argv
    machine = Path(args[0]) if args else TRUNNION
    if not SMALL_SPEC.is_file() or not machine.is_file():
        print(f"numba kernels not warmed: {SMALL_SPEC if not SMALL_SPEC.is_file() else machine}"
              " not found", file=sys.stderr)
        return 0
    # killed when the run it serves ends: leave through SystemExit, so that the
    # temporary folder is removed
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="impeller-cam-warm-") as folder:
        warm(Path(folder) / "small", machine)
    print(f"numba kernels warmed in {time.monotonic() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
