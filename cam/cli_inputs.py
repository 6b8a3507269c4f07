"""CLI commands around the input files: ``design``, ``check``, ``tools``, ``example``.

* ``impeller-cam design DESIGN.toml -o DIR``: spec.toml + camber CSVs + figures.json
  (D2, b2, wrap, blade angles, d_min, r_max, largest fillet), all or nothing.
* ``impeller-cam check FILE...``: validates each file by its kind (``cam.inputs``).
* ``impeller-cam tools [LIBRARY]``: the tools of a library with their parts.
* ``impeller-cam example NAME -o DIR``: a bundled example spec folder to start from.

Registered on the main app by ``cam.cli``; bad input is an ``InputError`` (exit 2).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Annotated

import typer

from impeller_cam.errors import InputError

__all__ = ["register"]


def design_command(
    design: Annotated[Path, typer.Argument(help="Design parameters (design.toml).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
) -> None:
    """Generate an impeller spec from design parameters: spec.toml, CSVs, figures.json."""
    import tomllib

    from cam.inputs import check_options
    from geometry.design import generate, load_design
    from geometry.design_files import write_generated
    from geometry.design_summary import design_figures, summary_text
    from geometry.machining import read_machining

    params = load_design(design)
    check_options(read_machining(tomllib.loads(params.machining_toml)), design)
    generated = generate(params)
    figures = design_figures(generated)
    text = json.dumps(figures, indent=2, sort_keys=True) + "\n"
    write_generated(generated, out, extra={"figures.json": text})
    typer.echo(summary_text(figures))
    typer.echo(f"wrote {out / 'spec.toml'}")


def check_command(
    files: Annotated[list[Path], typer.Argument(help="Input files (TOML; .tbl tool tables).")],
    kind: Annotated[
        str | None, typer.Option("--kind", help="spec, design, machine, tools, plant or "
                                 "feed-drive (default: told from the content).")
    ] = None,
) -> None:
    """Validate input files by their kind; exit 2 when any is refused."""
    from cam.inputs import check_file

    failed = 0
    for path in files:
        try:
            found, what = check_file(path, kind)
        except InputError as error:
            typer.echo(f"impeller-cam: error: {error}", err=True)
            failed += 1
            continue
        typer.echo(f"{path}: ok ({found}) {what}")
    if failed:
        raise typer.Exit(code=2)


def tools_command(
    library: Annotated[
        Path | None, typer.Argument(help="Tool library (TOML or LinuxCNC .tbl; default: "
                                    "the bundled one).")
    ] = None,
) -> None:
    """List the tools of a library with cutter, shank and holder."""
    from cam.tools import DEFAULT_LIBRARY, load_tool_library

    path = library or DEFAULT_LIBRARY
    for tool in load_tool_library(path).values():
        cutter = f"{tool.shape} D{tool.diameter:g}"
        if tool.shape == "bullnose":
            cutter += f" r{tool.corner_radius:g}"
        if tool.flute_taper_deg:
            cutter += f" tapered {tool.flute_taper_deg:g} deg"
        neck = f", taper {tool.taper_deg:g} deg" if tool.taper_deg else ""
        holder = " + ".join(
            f"{s.z1 - s.z0:g} x D{2 * s.r0:g}" + ("" if s.r0 == s.r1 else f"-{2 * s.r1:g}")
            for s in tool.holder) or "none"
        typer.echo(f"T{tool.number} {tool.name}: cutter {cutter}, flutes {tool.flute_length:g}, "
                   f"shank D{tool.shank_diameter:g}{neck}, stick-out {tool.stickout:g}, "
                   f"holder {holder} (mm)")


def example_command(
    name: Annotated[str, typer.Argument(help="Example impeller: small, nine_blade, splitter.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder to write the example to.")],
) -> None:
    """Write a bundled example impeller (spec.toml, design.toml, camber CSVs) to start from."""
    from impeller_cam.atomic import staged_directory
    from impeller_cam.data import example_folder

    source = example_folder(name)
    with staged_directory(out) as stage:
        for item in sorted(source.iterdir()):
            if item.is_file():
                shutil.copyfile(item, stage / item.name)
    typer.echo(f"wrote {out / 'spec.toml'} (run it: impeller-cam run {out / 'spec.toml'} "
               f"-m trunnion-500 -o OUT)")


def register(app: typer.Typer) -> None:
    """Add the input-file commands to the main app."""
    app.command("design")(design_command)
    app.command("check")(check_command)
    app.command("tools")(tools_command)
    app.command("example")(example_command)
