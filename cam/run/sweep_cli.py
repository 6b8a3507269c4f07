"""``impeller-cam sweep``: design variants on Dask (``cam.run.sweep.run_sweep``).

Exit codes: 0 every variant done; 3 the sweep ran and wrote its table but some
variants are invalid or failed (their rows say why); 2 bad input to the sweep itself
(base design, ``--vary``, options, machine, unreachable scheduler: nothing written);
1 an internal error.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

__all__ = ["SOME_VARIANTS_FAILED", "sweep_command"]

#: Exit code when the sweep completed but not every variant is done.
SOME_VARIANTS_FAILED = 3


def sweep_command(
    design: Annotated[Path, typer.Argument(help="Base design (design.toml).")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    vary: Annotated[
        list[str], typer.Option("--vary", help="PATH=V1,V2,... or PATH=START:STOP:COUNT "
                                "(repeatable), e.g. blades=7,9,11, "
                                "camber.shroud.beta_deg[2]=-34:-42:4.")
    ],
    samples: Annotated[
        int | None, typer.Option(help="Latin hypercube of N variants (default: the cross "
                                 "product).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of the Latin hypercube.")] = 0,
    stages: Annotated[
        str, typer.Option(help="Last stage run: design, geometry, rough, finish or all.")
    ] = "rough",
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="Address of a running Dask scheduler "
                                 "(default: a local cluster).")
    ] = None,
    workers: Annotated[int, typer.Option(help="Local Dask worker processes.")] = 2,
    tool: Annotated[
        str | None, typer.Option("-t", "--tool", help="Tool for both operations (over the "
                                 "design's machining table).")
    ] = None,
    rough_tool: Annotated[str | None, typer.Option("--rough-tool", help="Roughing tool.")
                          ] = None,
    finish_tool: Annotated[str | None, typer.Option("--finish-tool", help="Finishing tool.")
                           ] = None,
    library: Annotated[
        Path | None, typer.Option("--library", help="Tool library TOML (sent to the "
                                  "workers; default the bundled one).")
    ] = None,
    resolution: Annotated[
        float | None, typer.Option("--resolution", help="Verification dexel spacing, mm.")
    ] = None,
    files: Annotated[
        str, typer.Option(help="Files kept per variant: json (design, spec, JSON files) "
                          "or all (STEP, STL, APT, renders too).")
    ] = "json",
    retries: Annotated[int, typer.Option(help="Dask retries of a task that raised.")] = 2,
) -> None:
    """Design variants through the chain on Dask: OUT/sweep.csv, .parquet, .html.

    Exit code 0: every variant done; 3: some variants invalid or failed (their rows say
    why); 2: bad input (nothing written). docs/sweep.md.
    """
    from cam.cli import _machine
    from cam.run.sweep import run_sweep

    settings: dict[str, Any] = {key: value for key, value in (
        ("tool", tool), ("rough_tool", rough_tool), ("finish_tool", finish_tool),
        ("verify_resolution_mm", resolution)) if value is not None}
    summary = run_sweep(design, list(vary), _machine(machine), out, samples=samples,
                        seed=seed, stages=stages, scheduler=scheduler, workers=workers,
                        library=library, files=files, retries=retries, **settings)
    for entry in summary["variants"]:
        if entry["status"] != "done":
            where = f" ({entry['stage']})" if entry["stage"] else ""
            typer.echo(f"{entry['name']}: {entry['status']}{where}: {entry['error']}",
                       err=True)
    typer.echo(f"{summary['done']} done, {summary['failed']} failed, {summary['invalid']} "
               f"invalid: {Path(out) / 'sweep.csv'}, {Path(out) / 'sweep.html'}")
    if summary["done"] != len(summary["variants"]):
        raise typer.Exit(code=SOME_VARIANTS_FAILED)
