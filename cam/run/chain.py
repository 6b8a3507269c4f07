"""``run_chain``: the whole chain for one spec, stage by stage, recorded in run.json.

Stages (``cam.run.record.STAGES``): geometry, rough, finish, post, verify, motion,
report. Each writes its own folder all or nothing. A failed stage is recorded
(``status: "failed"`` with its error), the later stages stay ``"not run"``, earlier
outputs are untouched, and the error is raised again (the CLI turns an
``InputError`` into exit code 2, anything else into 1). ``only`` reruns one stage and
``start`` runs from a stage to the end, from the outputs of the earlier stages on disk;
stages after a rerun one are marked ``"stale": true`` in run.json.
"""

from __future__ import annotations

import traceback
from collections.abc import Mapping
from contextlib import nullcontext
from pathlib import Path
from typing import Any

from cam.run.record import (
    STAGES,
    MemoryMeter,
    empty_record,
    read_record,
    stage_entry,
    write_record,
)
from cam.run.settings import resolve_settings
from cam.run.stages import STAGE_FUNCTIONS, Context, stage_outputs
from impeller_cam.errors import InputError
from impeller_cam.progress import StageLog, progress_bar

__all__ = ["impeller_name", "run_chain", "selected_stages"]


def impeller_name(spec: str | Path) -> str:
    """The impeller's name (``[impeller] name``, else the spec's folder name)."""
    import tomllib

    path = Path(spec)
    if not path.is_file():
        raise InputError("spec file not found", file=path, value=str(path),
                         accepted="an existing impeller spec TOML")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None
    table = data.get("impeller", {})
    name = table.get("name") if isinstance(table, dict) else None
    return str(name) if isinstance(name, str) and name else path.parent.name


def selected_stages(only: str | None, start: str | None) -> list[str]:
    """The stages to run for ``--stage`` / ``--from`` (all when neither is given)."""
    if only is not None and start is not None:
        raise InputError("give --stage or --from, not both", field="--stage/--from",
                         value=f"{only}/{start}", accepted="one of them")
    for flag, value in (("--stage", only), ("--from", start)):
        if value is not None and value not in STAGES:
            raise InputError("unknown stage", field=flag, value=value,
                             accepted=", ".join(STAGES))
    if only is not None:
        return [only]
    return list(STAGES[STAGES.index(start):]) if start is not None else list(STAGES)


def _message(error: BaseException) -> str:
    if isinstance(error, InputError):
        return str(error)
    return f"{type(error).__name__}: {error}"


def run_chain(
    spec: str | Path,
    machine: str | Path,
    out: str | Path,
    *,
    rough_tool: str | None = None,
    finish_tool: str | None = None,
    tool: str | None = None,
    post: str | None = None,
    only: str | None = None,
    start: str | None = None,
    progress: bool | None = None,
    rough: Mapping[str, Any] | None = None,
    finish: Mapping[str, Any] | None = None,
    fillet_tool: str | None = None,
    verify_resolution_mm: float | None = None,
    tessellation_mm: float | None = None,
    servo: bool | None = None,
    indexing_grid: str | None = None,
    post_options: Mapping[str, str] | None = None,
    tcp: bool | None = None,
) -> dict[str, Any]:
    """Run the chain (or some stages of it) for one impeller spec.

    Parameters
    ----------
    spec : str or Path
        Impeller spec TOML (its optional ``[machining]`` table gives tools and
        settings, see ``cam.run.settings``).
    machine : str or Path
        Machine TOML.
    out : str or Path
        Output folder (layout: docs/run.md).
    rough_tool, finish_tool, tool : str, optional
        Tool overrides (``tool``: both, as ``-t``).
    post : str, optional
        Post-processor (default: the spec's, else the machine's).
    only : str, optional
        Rerun this stage alone from the earlier stages' outputs.
    start : str, optional
        Run from this stage to the end.
    progress : bool, optional
        Progress bar across stages (default: when stderr is a terminal).
    rough, finish : mapping, optional
        ``RoughOptions`` / ``FinishOptions`` fields (mm, deg) over the spec's
        ``[machining.rough]`` / ``[machining.finish]`` tables, key by key.
    fillet_tool : str, optional
        Ball of the fillet pencil passes (default: the spec's, else chosen).
    verify_resolution_mm : float, optional
        Dexel spacing of the verifications (default: the spec's, else 0.1 mm).
    tessellation_mm : float, optional
        Tessellation of the geometry stage's STL and render (default: the spec's).
    servo : bool, optional
        Run the motion stage's servo-lag prediction (default True).
    indexing_grid : str, optional
        ``"coarse"`` (default) or ``"paper"`` (the motion stage's index optimisation).
    post_options : mapping of str to str, optional
        Dialect options (``--post-option KEY=VALUE``) over the machine file's.
    tcp : bool, optional
        Post under tool-centre-point control (default: machine joints).

    Returns
    -------
    dict
        The run.json content.

    Raises
    ------
    InputError
        Bad input (before any stage: nothing written; in a stage: recorded in run.json).
    Exception
        A stage's internal error, after it is recorded in run.json.
    """
    spec, machine, out = Path(spec), Path(machine), Path(out)
    given = {"rough": rough, "finish": finish, "fillet_tool": fillet_tool,
             "verify_resolution_mm": verify_resolution_mm, "tessellation_mm": tessellation_mm,
             "servo": servo, "indexing_grid": indexing_grid,
             "post_options": dict(post_options) if post_options else None, "tcp": tcp}
    settings = {key: value for key, value in given.items() if value is not None}
    if not machine.is_file():
        raise InputError("machine file not found", file=machine, field="-m",
                         value=str(machine), accepted="an existing machine TOML")
    names = selected_stages(only, start)
    from cam.inputs import check_run_inputs

    # every file the run reads is checked before anything is written
    check_run_inputs(spec, machine, rough_tool=rough_tool, finish_tool=finish_tool,
                     tool=tool, post=post, **settings)
    run_settings = resolve_settings(spec, rough_tool=rough_tool, finish_tool=finish_tool,
                                    tool=tool, post=post, **settings)
    ctx = Context(spec=spec, machine=machine, out=out, settings=run_settings)
    fresh = empty_record(spec, machine, impeller_name(spec), run_settings.as_dict())
    record = fresh
    if names != list(STAGES):
        earlier = read_record(out)
        if earlier is not None:
            record = {**earlier, **{k: fresh[k] for k in ("settings", "tools", "post",
                                                        "versions", "machine", "spec")}}
    entries = {e["name"]: e for e in record["stages"]}
    for name in STAGES:
        entries.setdefault(name, stage_entry(name))
    record["stages"] = [entries[n] for n in STAGES]
    for name in STAGES[STAGES.index(names[0]):]:
        if name in names:
            entries[name].update(stage_entry(name))
        elif only is not None and entries[name]["status"] == "done":
            entries[name]["stale"] = True
    out.mkdir(parents=True, exist_ok=True)
    write_record(out, record)
    bar = progress_bar(progress)
    log = StageLog(record["impeller"]) if progress is None and bar is None else None
    with bar if bar is not None else nullcontext(), log if log is not None else nullcontext():
        task = bar.add_task("chain", total=len(names)) if bar is not None else None
        for done, name in enumerate(names):
            if bar is not None:
                bar.update(task, completed=done, description=f"{name} ({done + 1}/"
                           f"{len(names)})")
            if log is not None:
                log.start(name, done + 1, len(names))
            entry = entries[name]
            entry.pop("stale", None)
            meter = MemoryMeter()
            try:
                with meter.measure():
                    STAGE_FUNCTIONS[name](ctx)
            except BaseException as error:
                entry.update(status="failed", seconds=round(meter.seconds, 3),
                             peak_mb=round(meter.peak_mb, 1), error=_message(error),
                             outputs=[])
                if not isinstance(error, InputError | KeyboardInterrupt):
                    entry["traceback"] = traceback.format_exc(limit=8)
                write_record(out, record)
                if log is not None:
                    log.end("failed")
                raise
            entry.update(status="done", seconds=round(meter.seconds, 3),
                         cpu_seconds=round(meter.cpu_seconds, 3),
                         peak_mb=round(meter.peak_mb, 1), peak_mb_kind=meter.kind,
                         outputs=stage_outputs(out, name), error=None)
            write_record(out, record)
            if log is not None:
                log.end()
        if bar is not None:
            bar.update(task, completed=len(names))
    return record
