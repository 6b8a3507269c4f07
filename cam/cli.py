"""The ``impeller-cam`` command line: one console script, one sub-command per stage.

Each sub-command is a thin shell over a library function; heavy imports happen
inside the command so ``impeller-cam --help`` and ``impeller-cam posts`` stay fast.
Exit codes: 0 success, 2 bad input (one message naming file, field, value and what
is accepted), 1 internal error.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from impeller_cam.errors import InputError

app = typer.Typer(
    name="impeller-cam",
    help="CAD/CAM for centrifugal impellers: geometry, roughing, finishing, post, verification.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _report_verdict(out: Path) -> None:
    """After a chain: warn of milled faces over the limit, and end with exit code 1 when
    the verification found a program unsafe (``cam.run.verdict``)."""
    from cam.run.verdict import chain_verdict

    verdict = chain_verdict(out)
    for line in verdict.shortfalls:
        typer.echo(f"warning: {line}", err=True)
    if not verdict.safe:
        for line in verdict.faults:
            typer.echo(f"error: verification failed: {line}", err=True)
        typer.echo("error: do not run these NC programs: the verification found them "
                   "unsafe", err=True)
        raise typer.Exit(code=1)


def _machine(path: Path) -> Path:
    """``-m``: a machine file, or the name of a bundled one (``trunnion-500``)."""
    from impeller_cam.data import bundled

    return bundled(path, "machines")


@app.command("geometry")
def geometry_command(
    spec: Annotated[Path, typer.Argument(help="Impeller spec (TOML).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    tessellation: Annotated[
        float, typer.Option(help="Linear deflection of the STL/mesh tessellation, mm.")
    ] = 0.02,
    render: Annotated[bool, typer.Option(help="Write the offscreen PNG render.")] = True,
    fillets: Annotated[
        bool,
        typer.Option(help="Build the blade-to-hub fillets (--no-fillets: a solid without them)."),
    ] = True,
) -> None:
    """Build the impeller: impeller.step, impeller.stl, geometry.json, impeller.png."""
    from geometry.command import run_geometry

    run_geometry(spec, out, tessellation=tessellation, render=render, fillets=fillets)


@app.command("import")
def import_command(
    source: Annotated[Path, typer.Argument(help="BladeGen FILE.inf or CFturbo FILE.cft-geo.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output spec folder.")],
    manufacturing: Annotated[
        Path | None, typer.Option(help="TOML with [hub], [blade] fillet_radius_mm, "
                                  "[allowances], [machining] (default: manufacturing.toml "
                                  "beside the file, if any).")
    ] = None,
    check_solid: Annotated[
        bool, typer.Option(help="Build the solid and report the section points' distance.")
    ] = True,
) -> None:
    """Import an aero design: spec.toml, camber CSVs, import_report.json/.txt."""
    from geometry.exchange.command import run_import

    typer.echo(run_import(source, out, manufacturing=manufacturing, check_solid=check_solid),
               nl=False)


@app.command("export")
def export_command(
    spec: Annotated[Path, typer.Argument(help="Impeller spec (TOML).")],
    fmt: Annotated[str, typer.Option("--format", help="bladegen or cft-geo.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    units: Annotated[str, typer.Option(help="Length unit of the files: M, CM, MM, IN.")] = "MM",
    spans: Annotated[int, typer.Option(help="Spans written, hub to shroud.")] = 5,
) -> None:
    """Export a spec as BladeGen/TurboGrid curve files or a CFturbo .cft-geo file."""
    from geometry.exchange.command import run_export

    for name in run_export(spec, fmt, out, unit=units, spans=spans):
        typer.echo(f"wrote {out / name}")


@app.command("finish")
def finish_command(
    spec: Annotated[Path, typer.Argument(help="Impeller spec (TOML).")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    tool: Annotated[str, typer.Option("-t", "--tool", help="NAME or LIBRARY.toml:NAME.")],
    out: Annotated[Path | None, typer.Option("-o", "--out", help="Output folder.")] = None,
    scallop: Annotated[float, typer.Option(help="Allowed scallop height, mm.")] = 0.02,
    spacing: Annotated[float, typer.Option(help="Point spacing along a path, mm.")] = 0.25,
    chordal_tol: Annotated[
        float | None,
        typer.Option("--chordal-tol", help="Chordal tolerance, mm: each path's spacing "
                     "is lowered below --spacing from its curvature (default: none)."),
    ] = None,
    passages: Annotated[
        int | None, typer.Option(help="Finish only the first N passages (default: all).")
    ] = None,
    plots: Annotated[bool, typer.Option(help="Write the A/C displacement plots.")] = True,
    fillet_tool: Annotated[
        str | None, typer.Option("--fillet-tool", help="Ball no larger than the fillet: "
                                 "also finish the fillets (finish_fillet.apt).")
    ] = None,
    stock: Annotated[
        str | None,
        typer.Option(help="In-process stock: a verified stock.npz (or a spec's blank, a "
                     "closed mesh); shank and holder keep --stock-clearance from its "
                     "material beyond --clearance minus that from the design."),
    ] = None,
    clearance: Annotated[
        float, typer.Option(help="Clearance of shank and holder from the design, mm.")
    ] = 0.5,
    stock_clearance: Annotated[
        float, typer.Option(help="Clearance of shank and holder from the --stock, mm.")
    ] = 0.5,
    blade_strategy: Annotated[
        str, typer.Option("--blade-strategy", help="Blade sides: point (ball passes), swarf "
                          "(flank passes along the rulings) or swarf_or_point (flank passes, "
                          "ball passes on what they leave).")
    ] = "point",
    check_swarf: Annotated[
        bool, typer.Option("--check-swarf", help="Print the rule deviation and the "
                           "predicted swarf deviation per band; write nothing.")
    ] = False,
) -> None:
    """Five-axis finishing: APT per operation, finish.json, A/C displacement plots."""
    from cam.finishing.command import run_finish
    from cam.finishing.options import BLADE_STRATEGIES, FinishOptions

    if blade_strategy not in BLADE_STRATEGIES:
        raise InputError("unknown blade strategy", field="--blade-strategy",
                         value=blade_strategy, accepted=", ".join(BLADE_STRATEGIES))
    options = FinishOptions.from_mapping({
        "scallop_mm": scallop, "point_spacing_mm": spacing, "chordal_tolerance_mm": chordal_tol,
        "passages": passages, "clearance_mm": clearance,
        "clearance_exact_mm": max(clearance, 3.0), "stock_clearance_mm": stock_clearance,
        "blade_strategy": blade_strategy})
    if check_swarf:
        from cam.finishing.swarf_plan import swarf_check_text
        from cam.tools import resolve_tool
        from geometry.spec import load_spec
        from geometry.surfaces import build_surfaces

        the_tool = resolve_tool(tool)
        typer.echo(swarf_check_text(build_surfaces(load_spec(spec)), the_tool, options),
                   nl=False)
        return
    if out is None:
        raise InputError("an output folder is needed", field="-o", value="(none)",
                         accepted="-o FOLDER (or --check-swarf, which writes nothing)")
    run_finish(spec, _machine(machine), tool, out, options=options, plots=plots,
               fillet_tool=fillet_tool, stock=stock)


@app.command("rough")
def rough_command(
    spec: Annotated[Path, typer.Argument(help="Impeller spec (TOML).")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    tool: Annotated[str, typer.Option("-t", "--tool", help="NAME or LIBRARY.toml:NAME.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    scallop: Annotated[float, typer.Option(help="Allowed scallop height, mm.")] = 0.5,
    passages: Annotated[int, typer.Option(help="Rough only the first N passages (0: all).")] = 0,
    max_depth: Annotated[
        float, typer.Option(help="Largest cutting depth per layer a_p, mm (0: tool radius).")
    ] = 0.0,
    step_along: Annotated[
        float, typer.Option(help="CL point spacing along a pass, mm.")
    ] = 1.0,
    baseline_layering: Annotated[
        str, typer.Option(help="Layers of the five-axis baseline: ruling (eq. 2, the "
                          "paper's) or depth (the 3+2 plan's layers by milling depth).")
    ] = "ruling",
    compare: Annotated[
        bool, typer.Option(help="Also plan, time and check the paper's simultaneous "
                           "five-axis baseline and write its Table 1 (table1.md).")
    ] = False,
) -> None:
    """Three-axis roughing by Unit Machining Regions (3+2): APT per UMR, rough.json."""
    from cam.roughing.command import run_rough
    from cam.roughing.options import RoughOptions

    options = RoughOptions.from_mapping({
        "scallop_mm": scallop, "passages": passages, "max_depth_mm": max_depth,
        "step_along_mm": step_along, "baseline_layering": baseline_layering})
    run_rough(spec, _machine(machine), tool, out, options=options, compare=compare)


@app.command("verify")
def verify_command(
    programs: Annotated[list[Path], typer.Argument(help="NC programs, run in order.")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    tool: Annotated[str, typer.Option("-t", "--tool", help="NAME or LIBRARY.toml:NAME.")],
    stock: Annotated[
        str, typer.Option("--stock", help="cylinder:D,H | spec TOML (its blank) | STL | .npz")
    ],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    design: Annotated[
        Path | None, typer.Option("--design", help="Impeller spec or mesh to check against.")
    ] = None,
    resolution: Annotated[float, typer.Option(help="Dexel spacing, mm.")] = 0.1,
) -> None:
    """Material-removal verification of NC programs: verify.json, report.html, JUnit."""
    from cam.verify.command import run_verify

    run_verify(programs, _machine(machine), tool, stock, design, resolution, out)


@app.command("post")
def post_command(
    apt: Annotated[Path, typer.Argument(help="APT CLDATA file (workpiece frame).")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="NC program to write.")],
    post: Annotated[
        str | None,
        typer.Option("--post", help="Post-processor name (see `impeller-cam posts`)."),
    ] = None,
    tcp: Annotated[bool, typer.Option("--tcp", help="Post for tool-centre-point control.")] = False,
    tolerance: Annotated[
        float, typer.Option("--tolerance", help="Chordal tolerance of the tool tip, mm.")
    ] = 0.01,
    angular_tolerance: Annotated[
        float,
        typer.Option(
            "--angular-tolerance",
            help="Angular tolerance of the tool axis between two CL records, deg.",
        ),
    ] = 0.5,
    block_numbers: Annotated[bool, typer.Option(help="Number the blocks (N words).")] = False,
    program_number: Annotated[
        int | None, typer.Option(help="Program number (O word), dialects that use one.")
    ] = None,
    post_option: Annotated[
        list[str] | None,
        typer.Option("--post-option", help="Dialect option KEY=VALUE (repeatable; "
                     "`impeller-cam posts` lists them), over the machine file's."),
    ] = None,
) -> None:
    """Post an APT file for a machine: atomic, deterministic NC output."""
    from postproc.command import run_post
    from postproc.posts.choices import parse_option_words

    run_post(
        apt,
        _machine(machine),
        out,
        post=post,
        tcp=tcp,
        tolerance=tolerance,
        angular_tolerance_deg=angular_tolerance,
        block_numbers=block_numbers,
        program_number=program_number,
        post_options=parse_option_words(post_option or []),
    )


@app.command("run")
def run_command(
    specs: Annotated[list[Path], typer.Argument(help="Impeller spec(s); several: a batch.")],
    machine: Annotated[Path, typer.Option("-m", "--machine", help="Machine TOML (or a "
                                          "bundled one: trunnion-500, xyzac-trt).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Output folder.")],
    tool: Annotated[
        str | None, typer.Option("-t", "--tool", help="Tool for both operations "
                                 "(NAME or LIBRARY.toml:NAME).")
    ] = None,
    rough_tool: Annotated[
        str | None, typer.Option("--rough-tool", help="Roughing tool (over the spec's).")
    ] = None,
    finish_tool: Annotated[
        str | None, typer.Option("--finish-tool", help="Finishing tool (over the spec's).")
    ] = None,
    fillet_tool: Annotated[
        str | None, typer.Option("--fillet-tool", help="Fillet pencil tool (over the "
                                 "spec's; default the library's largest ball <= r_f).")
    ] = None,
    post: Annotated[
        str | None, typer.Option("--post", help="Post-processor (default: the machine's).")
    ] = None,
    post_option: Annotated[
        list[str] | None,
        typer.Option("--post-option", help="Dialect option KEY=VALUE (repeatable; "
                     "`impeller-cam posts` lists them), over the machine file's."),
    ] = None,
    tcp: Annotated[bool, typer.Option(help="Post under tool-centre-point control "
                                      "(default: machine joints).")] = False,
    stage: Annotated[
        str | None, typer.Option("--stage", help="Rerun this stage alone from the outputs "
                                 "on disk (geometry, rough, finish, post, verify, motion, "
                                 "report).")
    ] = None,
    start: Annotated[
        str | None, typer.Option("--from", help="Run from this stage to the end.")
    ] = None,
    resolution: Annotated[
        float | None, typer.Option("--resolution", help="Verification dexel spacing, mm "
                                   "(over the spec's).")
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="Batch: address of a running Dask "
                                 "scheduler (default: a local cluster).")
    ] = None,
    workers: Annotated[int, typer.Option(help="Batch: local Dask worker processes.")] = 2,
) -> None:
    """The whole chain: geometry, rough, finish, post, verify, motion, report.html."""
    settings: dict[str, object] = {}
    if resolution is not None:
        settings["verify_resolution_mm"] = resolution
    if fillet_tool is not None:
        settings["fillet_tool"] = fillet_tool
    if post_option:
        from postproc.posts.choices import parse_option_words

        settings["post_options"] = dict(parse_option_words(post_option))
    if tcp:
        settings["tcp"] = True
    options: dict[str, Any] = dict(rough_tool=rough_tool, finish_tool=finish_tool, tool=tool,
                                   post=post,
                                   only=stage, start=start, **settings)
    if len(specs) == 1 and scheduler is None:
        from cam.run import run_chain

        run_chain(specs[0], _machine(machine), out, **options)  # bad input: nothing written
        _report_verdict(out)
        return
    from cam.run import run_batch

    summary = run_batch(list(specs), _machine(machine), out, scheduler=scheduler, workers=workers,
                        **options)
    for entry in summary["specs"]:
        where = f" in stage {entry['stage']}" if entry["stage"] else ""
        line = f"{entry['name']}: {entry['status']}{where} ({entry['seconds']:.0f} s)"
        typer.echo(line if entry["status"] == "done" else f"{line}: {entry['error']}",
                   err=entry["status"] != "done")
    if summary["failed"]:
        kinds = {e["kind"] for e in summary["specs"] if e["status"] == "failed"}
        raise typer.Exit(code=2 if kinds == {"input"} else 1)


@app.command("posts")
def posts_command() -> None:
    """List the registered post-processors (built-ins and entry-point plug-ins)."""
    from postproc.command import run_posts

    run_posts()


def _version(show: bool) -> None:
    if show:
        from impeller_cam import __version__

        typer.echo(f"impeller-cam {__version__}")
        raise typer.Exit()


@app.callback()
def _options(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True,
                           help="Print the version and exit.")
    ] = False,
) -> None:
    """CAD/CAM for centrifugal impellers: geometry, roughing, finishing, post, verification."""


def _mount() -> None:
    from cam.cli_inputs import register
    from cam.motion.cli import motion_app
    from cam.run.sweep_cli import sweep_command

    app.add_typer(motion_app, name="motion")
    app.command("sweep")(sweep_command)
    register(app)


_mount()


def _usage_errors() -> tuple[type[Exception], ...]:
    """Click's usage-error base classes (typer may vendor its own click)."""
    import click

    kinds: list[type[Exception]] = [click.ClickException]
    try:
        from typer._click.exceptions import ClickException
    except ImportError:  # pragma: no cover - typer without a vendored click
        return tuple(kinds)
    return (*kinds, ClickException)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and map errors to exit codes (2 bad input, 1 internal error)."""
    try:
        code = app(args=argv, standalone_mode=False)
    except InputError as error:
        typer.echo(f"impeller-cam: error: {error}", err=True)
        return 2
    except typer.Exit as done:
        return int(done.exit_code)
    except typer.Abort:
        typer.echo("impeller-cam: aborted", err=True)
        return 1
    except Exception as error:  # click usage errors are ClickException
        if isinstance(error, _usage_errors()):
            error.show()  # type: ignore[attr-defined]
            return 2
        if os.environ.get("IMPELLER_CAM_DEBUG"):
            raise
        typer.echo(f"impeller-cam: internal error: {type(error).__name__}: {error}", err=True)
        return 1
    return code if isinstance(code, int) else 0  # typer.Exit(code) in non-standalone mode


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
