"""Settings of one chain run: the spec's ``[machining]`` table and the CLI overrides.

Precedence: a command-line option (``--rough-tool``, ``--finish-tool``, ``-t``,
``--post``, keyword settings of ``run_chain``) beats the spec's ``[machining]`` table,
which beats the defaults below. ``-t`` alone sets both tools. Option names of the
roughing and finishing sub-tables are checked here against ``RoughOptions`` and
``FinishOptions``; a bad one is an ``InputError`` naming the spec file and the
dotted field.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from geometry.machining import RESOLUTION_RANGE, MachiningSettings, machining_of
from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES

__all__ = ["DEFAULT_RESOLUTION", "RunSettings", "resolve_settings"]

#: Verification dexel spacing when neither the spec nor the caller gives one, mm.
DEFAULT_RESOLUTION = 0.1
#: Keyword settings ``run_chain`` accepts besides the tools and the post.
SETTING_KEYS = ("rough", "finish", "verify_resolution_mm", "tessellation_mm", "servo",
                "indexing_grid", "fillet_tool", "post_options", "tcp")


@dataclass(frozen=True)
class RunSettings:
    """Everything a chain run needs to know besides spec, machine and output folder.

    Attributes
    ----------
    rough_tool, finish_tool : str
        Tool names (library name or ``LIBRARY.toml:NAME``).
    fillet_tool : str or None
        Ball of the fillet pencil passes (``None``: the finish stage chooses the
        library's largest ball no larger than the fillet, or plans no fillet pass).
    post : str or None
        Post-processor (``None``: the machine's default dialect).
    post_options : dict of str to str
        Dialect options (``--post-option KEY=VALUE``) over the machine file's
        ``[control.options]``.
    tcp : bool
        Post under tool-centre-point control (``--tcp``; default joint positions).
    verify_resolution_mm : float
        Dexel spacing of both verifications, mm.
    tessellation_mm : float
        Tessellation of the geometry stage's STL and render, mm.
    rough, finish : dict
        Keyword options of ``run_rough`` / ``run_finish``.
    servo : bool
        Run the servo-lag prediction of the motion stage.
    indexing_grid : str
        ``"coarse"`` (a few thousand profiles, seconds) or ``"paper"`` (the paper's
        4.8 million profiles).
    """

    rough_tool: str
    finish_tool: str
    post: str | None = None
    verify_resolution_mm: float = DEFAULT_RESOLUTION
    tessellation_mm: float = DEFAULT_TOLERANCES.tessellation
    rough: dict[str, Any] = field(default_factory=dict)
    finish: dict[str, Any] = field(default_factory=dict)
    servo: bool = True
    indexing_grid: str = "coarse"
    fillet_tool: str | None = None
    post_options: dict[str, str] = field(default_factory=dict)
    tcp: bool = False

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (run.json ``settings``).

        Returns
        -------
        dict
        """
        return asdict(self)


def _check_options(kind: str, options: dict[str, Any], spec: Path) -> None:
    """Validate roughing/finishing options, naming the spec's dotted field on error."""
    if kind == "rough":
        from cam.roughing.options import RoughOptions as Options
    else:
        from cam.finishing.options import FinishOptions as Options  # type: ignore[assignment]
    try:
        Options.from_mapping(dict(options))
    except InputError as error:
        raise InputError(error.message, file=spec, field=f"machining.{kind}.{error.field}",
                         value=error.value, accepted=error.accepted) from None


def resolve_settings(
    spec: str | Path,
    *,
    rough_tool: str | None = None,
    finish_tool: str | None = None,
    tool: str | None = None,
    post: str | None = None,
    **settings: Any,
) -> RunSettings:
    """Merge the spec's ``[machining]`` table with the caller's overrides.

    Parameters
    ----------
    spec : str or Path
        Impeller spec TOML (only its ``[machining]`` table is read here).
    rough_tool, finish_tool : str, optional
        Override the spec's tools.
    tool : str, optional
        ``-t``: both tools, unless one of them is given explicitly.
    post : str, optional
        Post-processor name.
    **settings
        ``rough`` / ``finish`` (dicts merged over the spec's sub-tables, key by key),
        ``verify_resolution_mm``, ``tessellation_mm``, ``servo``, ``indexing_grid``,
        ``fillet_tool`` (over the spec's), ``post_options`` (dialect options),
        ``tcp`` (post under tool-centre-point control).

    Returns
    -------
    RunSettings
        Tools, post, verification resolution (mm), option dicts of the stages.

    Raises
    ------
    InputError
        Unknown setting, a tool given nowhere, bad option names or values.
    """
    spec = Path(spec)
    table: MachiningSettings = machining_of(spec)
    unknown = sorted(set(settings) - set(SETTING_KEYS))
    if unknown:
        raise InputError("unknown run setting", field=unknown[0], value=settings[unknown[0]],
                         accepted=", ".join(SETTING_KEYS))
    rough_name = rough_tool or tool or table.rough_tool
    finish_name = finish_tool or tool or table.finish_tool
    for name, value, flag in (("rough", rough_name, "--rough-tool"),
                              ("finish", finish_name, "--finish-tool")):
        if not value:
            raise InputError(f"no {name}ing tool given", file=spec,
                             field=f"machining.{name}_tool or {flag}",
                             accepted=f"{name}_tool = \"NAME\" in [machining], "
                                      f"{flag} NAME or -t NAME")
    rough = {**table.rough, **dict(settings.get("rough") or {})}
    finish = {**table.finish, **dict(settings.get("finish") or {})}
    _check_options("rough", rough, spec)
    _check_options("finish", finish, spec)
    resolution = settings.get("verify_resolution_mm") or table.verify_resolution_mm \
        or DEFAULT_RESOLUTION
    if not RESOLUTION_RANGE[0] <= float(resolution) <= RESOLUTION_RANGE[1]:
        raise InputError("verification resolution out of range",
                         field="verify_resolution_mm", value=resolution,
                         accepted=f"{RESOLUTION_RANGE[0]:g}..{RESOLUTION_RANGE[1]:g} mm")
    tessellation = settings.get("tessellation_mm") or table.tessellation_mm \
        or DEFAULT_TOLERANCES.tessellation
    grid = settings.get("indexing_grid", "coarse")
    if grid not in ("coarse", "paper"):
        raise InputError("unknown indexing grid", field="indexing_grid", value=grid,
                         accepted="coarse, paper")
    return RunSettings(
        rough_tool=str(rough_name), finish_tool=str(finish_name),
        post=post or table.post, verify_resolution_mm=float(resolution),
        tessellation_mm=float(tessellation), rough=rough, finish=finish,
        servo=bool(settings.get("servo", True)), indexing_grid=str(grid),
        fillet_tool=settings.get("fillet_tool") or table.fillet_tool,
        post_options={str(k): str(v) for k, v in (settings.get("post_options") or {}).items()},
        tcp=bool(settings.get("tcp", False)),
    )
