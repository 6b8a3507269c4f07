"""``impeller-cam post`` and ``impeller-cam posts``: thin shells over the library.

``run_post`` reads an APT file and a machine, posts with the chosen dialect and
writes the NC program atomically: on any error no file is written (an existing
file of that name is left untouched).
"""

from __future__ import annotations

from collections.abc import Mapping
from math import radians
from pathlib import Path
from typing import TYPE_CHECKING, Any

from impeller_cam.atomic import write_text_atomic
from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from postproc.posts import PostOptions, PostProcessor


def resolve_post(
    machine: Any,
    post: str | None,
    *,
    tcp: bool = False,
    tolerance: float = 0.01,
    angular_tolerance_deg: float = 0.5,
    block_numbers: bool = False,
    program_number: int | None = None,
    post_options: Mapping[str, str] | None = None,
) -> tuple[PostProcessor, PostOptions]:
    """The dialect and its checked ``PostOptions`` for a machine (nothing posted).

    Parameters
    ----------
    machine : postproc.machine.Machine
        The loaded machine file.
    post : str or None
        Dialect name (None: the machine's).
    tcp, tolerance, angular_tolerance_deg, block_numbers, program_number, post_options
        As ``run_post``'s (tolerance in mm, angular tolerance in degrees).

    Returns
    -------
    tuple
        ``(dialect, PostOptions)``.

    Raises
    ------
    InputError
        A non-positive tolerance, TCP on a dialect without it, an unknown dialect
        option or one the control does not have (vectors without TRAORI, ...).
    """
    from postproc.posts import PostOptions, get_post
    from postproc.posts.choices import options_for_machine

    if not tolerance > 0:
        raise InputError("chordal tolerance must be positive", field="--tolerance",
                         value=tolerance, accepted="a length > 0 mm")
    if not angular_tolerance_deg > 0:
        raise InputError("angular tolerance must be positive", field="--angular-tolerance",
                         value=angular_tolerance_deg, accepted="an angle > 0 deg")
    dialect = get_post(post or machine.post)
    if tcp and not dialect.supports_tcp:
        raise InputError(f"post-processor {dialect.name!r} cannot write TCP programs",
                         field="--tcp", value=True, accepted="a dialect with TCP support")
    options = PostOptions(
        tcp=tcp,
        chordal_tolerance=tolerance,
        angular_tolerance=radians(angular_tolerance_deg),
        block_numbers=block_numbers,
        program_number=program_number,
        dialect_options=options_for_machine(dialect, machine, post_options),
    )
    check = getattr(dialect, "check_options", None)
    if check is not None:
        check(options, machine)
    return dialect, options


def post_text(
    apt: str | Path,
    machine: str | Path,
    *,
    post: str | None = None,
    tcp: bool = False,
    tolerance: float = 0.01,
    angular_tolerance_deg: float = 0.5,
    block_numbers: bool = False,
    program_number: int | None = None,
    post_options: Mapping[str, str] | None = None,
) -> str:
    """Post an APT file for a machine and return the program text (nothing written).

    Parameters
    ----------
    apt : str or Path
        APT CLDATA file, poses in the workpiece frame W.
    machine : str or Path
        Machine TOML.
    post : str, optional
        Dialect name (``impeller-cam posts``); default: the machine's ``post``.
    tcp : bool
        Post for tool-centre-point control.
    tolerance : float
        Chordal tolerance of the tool tip, mm.
    angular_tolerance_deg : float
        Tolerance of the tool axis.
    block_numbers : bool
        Write ``N`` words.
    program_number : int, optional
        ``O`` number (dialects that use one), 1..9999.
    post_options : mapping of str to str, optional
        Dialect options over the machine file's ``[control.options]``.

    Returns
    -------
    str
        The NC program.

    Raises
    ------
    InputError
        As ``run_post``.
    """
    from postproc.apt import read_apt
    from postproc.machine import load_machine
    from postproc.posting import post_toolpaths

    the_machine = load_machine(machine)
    dialect, options = resolve_post(
        the_machine, post, tcp=tcp, tolerance=tolerance,
        angular_tolerance_deg=angular_tolerance_deg, block_numbers=block_numbers,
        program_number=program_number, post_options=post_options)
    toolpaths = read_apt(apt)
    posted = post_toolpaths(toolpaths, the_machine, options, source=Path(apt).name)
    return dialect.write(posted, options)


def run_post(
    apt: str | Path,
    machine: str | Path,
    out: str | Path,
    *,
    post: str | None = None,
    tcp: bool = False,
    tolerance: float = 0.01,
    angular_tolerance_deg: float = 0.5,
    block_numbers: bool = False,
    program_number: int | None = None,
    post_options: Mapping[str, str] | None = None,
) -> None:
    """Post an APT CLDATA file for a machine and write the NC program atomically.

    Parameters
    ----------
    apt : str or Path
        APT CLDATA file, poses in the workpiece frame W.
    machine : str or Path
        Machine TOML.
    out : str or Path
        NC program to write.
    post : str, optional
        Dialect name (``impeller-cam posts``); default: the machine's ``post``.
    tcp : bool
        Post for tool-centre-point control.
    tolerance : float
        Chordal tolerance of the tool tip, mm.
    angular_tolerance_deg : float
        Tolerance of the tool axis, degrees.
    block_numbers : bool
        Write ``N`` words.
    program_number : int, optional
        ``O`` number (dialects that use one), 1..9999.
    post_options : mapping of str to str, optional
        Dialect options (``--post-option KEY=VALUE``) over the machine file's
        ``[control.options]``.

    Raises
    ------
    InputError
        Bad input of any kind (files, options, over-travel naming the APT record,
        axis, value and limit); the output file is then not written.
    """
    text = post_text(apt, machine, post=post, tcp=tcp, tolerance=tolerance,
                     angular_tolerance_deg=angular_tolerance_deg,
                     block_numbers=block_numbers, program_number=program_number,
                     post_options=post_options)
    write_text_atomic(out, text)


def run_posts() -> None:
    """Print the registered post-processors: name, description and source."""
    import typer

    from postproc.posts import available_posts, get_post
    from postproc.posts.choices import declared_options

    rows = available_posts()
    widths = [max(len(row[i]) for row in rows + [("name", "description", "source")])
              for i in range(2)]
    typer.echo(f"{'name':<{widths[0]}}  {'description':<{widths[1]}}  source")
    for name, description, source in rows:
        typer.echo(f"{name:<{widths[0]}}  {description:<{widths[1]}}  {source}")
        try:
            declared = declared_options(get_post(name))
        except ImportError:
            declared = ()
        for option in declared:
            typer.echo(f"    --post-option {option.name}={'|'.join(option.choices)}: "
                       f"{option.description}")
