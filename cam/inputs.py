"""Every kind of input file: its declaration, its reader, how to tell it, its JSON Schema.

``KINDS`` lists the files a user writes (spec, design, machine, tool library, motion
plant, feed drives). ``check_file`` validates one file by its kind (guessed from its
content unless given) with the same readers the commands use; ``impeller-cam check``
is a shell over it. ``schemas`` gives the JSON Schema of each kind from the same
declarations; they are shipped in ``impeller_cam/schemas/`` and
``python -m cam.inputs`` rewrites them (a test checks they are up to date).
"""

from __future__ import annotations

import json
import sys
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from cam.motion.schema import FeedDriveFile, PlantFile
from cam.tools_schema import ToolLibraryFile
from geometry.design_schema import DesignFile
from geometry.machining import MachiningSettings, read_machining
from geometry.spec_schema import SpecFile
from impeller_cam.errors import InputError
from impeller_cam.options import options_model
from impeller_cam.schema import declared, json_schema, load_toml, with_file
from postproc.machine_schema import MachineFile

__all__ = ["KINDS", "InputKind", "check_file", "check_options", "check_run_inputs",
           "detect_kind", "schemas", "write_schemas"]

#: Where the JSON Schemas are shipped.
SCHEMA_FOLDER = Path(__file__).resolve().parents[1] / "impeller_cam" / "schemas"


@dataclass(frozen=True)
class InputKind:
    """One kind of input file.

    Attributes
    ----------
    name : str
        ``spec``, ``design``, ``machine``, ``tools``, ``plant``, ``feed-drive``.
    model : type of BaseModel
        Its declaration.
    title : str
        One line for the JSON Schema and ``check``.
    check : callable
        Reads and validates a file of this kind (raises ``InputError``); returns a
        one-line description of what was read.
    """

    name: str
    model: type[BaseModel]
    title: str
    check: Callable[[Path], str]


def check_options(machining: MachiningSettings, path: Path) -> None:
    """Check the option tables ``[machining.rough]`` / ``[machining.finish]``.

    Raises
    ------
    InputError
        Naming ``machining.rough.<key>`` (or ``finish``) in ``path``.
    """
    from cam.finishing.options import FinishOptions
    from cam.roughing.options import RoughOptions

    for key, options in (("rough", RoughOptions), ("finish", FinishOptions)):
        try:
            options.from_mapping(dict(getattr(machining, key)))  # type: ignore[attr-defined]
        except InputError as error:
            raise with_file(error, path, f"machining.{key}") from None


def check_run_inputs(spec: Path, machine: Path, **options: Any) -> None:
    """Check every file ``impeller-cam run`` will read, before anything is written.

    The spec (with its CSVs, geometry and option tables), the machine file and both
    tools (``options``: the keyword arguments of ``cam.run.run_chain`` that
    ``resolve_settings`` takes).

    Raises
    ------
    InputError
        The first problem.
    """
    from cam.run.settings import resolve_settings
    from cam.tools import resolve_tool
    from postproc.machine import load_machine

    _check_spec(spec)
    load_machine(machine)
    keys = ("rough_tool", "finish_tool", "tool", "post", "rough", "finish",
            "verify_resolution_mm", "tessellation_mm", "servo", "indexing_grid", "fillet_tool",
            "post_options", "tcp")
    settings = resolve_settings(spec, **{k: v for k, v in options.items() if k in keys})
    _check_post(machine, settings)
    resolve_tool(settings.rough_tool)
    resolve_tool(settings.finish_tool)
    if settings.fillet_tool is not None:
        from cam.finishing.fillet_plan import check_fillet_tool
        from geometry.spec import load_spec

        try:
            check_fillet_tool(resolve_tool(settings.fillet_tool),
                              float(load_spec(spec).fillet_radius))
        except InputError as error:
            raise with_file(error, spec, "machining") from None


def _check_post(machine: Path, settings: Any) -> None:
    """The chain's dialect, its options and TCP on this machine (``resolve_post``)."""
    from postproc.command import resolve_post
    from postproc.machine import load_machine

    resolve_post(load_machine(machine), settings.post, tcp=settings.tcp,
                 post_options=settings.post_options)


def _check_spec(path: Path) -> str:
    from geometry.spec import load_spec

    spec = load_spec(path)
    check_options(spec.machining, path)
    return f"impeller {spec.name!r}: {spec.blades} blades, {spec.splitters} splitter(s)"


def _check_design(path: Path) -> str:
    from geometry.design import generate, load_design

    params = load_design(path)
    check_options(read_machining(tomllib.loads(params.machining_toml)), path)
    generate(params)
    return f"design {params.name!r}: {params.blades} blades, law {params.angle_law}"


def _check_machine(path: Path) -> str:
    from postproc.machine import load_machine

    machine = load_machine(path)
    return f"machine {machine.name!r}: {machine.kinematics}, axes {''.join(machine.axes)}"


def _check_tools(path: Path) -> str:
    from cam.tools import load_tool_library

    tools = load_tool_library(path)
    return f"tool library: {', '.join(tools)}"


def _check_plant(path: Path) -> str:
    from cam.motion.plant import load_plant
    from cam.motion.positioning import settling_from_dict

    plant, document = load_plant(path)
    settling_from_dict(document, path)
    return f"plant: masses {plant.motor_mass:g} + {plant.table_mass:g} kg"


def _check_feed_drive(path: Path) -> str:
    from cam.motion.feeddrive import load_feed_drives

    return f"feed drives: axes {''.join(load_feed_drives(path))}"


KINDS: dict[str, InputKind] = {
    kind.name: kind
    for kind in (
        InputKind("spec", SpecFile, "impeller-cam impeller spec (spec.toml)", _check_spec),
        InputKind("design", DesignFile, "impeller-cam design parameters (design.toml)",
                  _check_design),
        InputKind("machine", MachineFile, "impeller-cam machine file", _check_machine),
        InputKind("tools", ToolLibraryFile, "impeller-cam tool library", _check_tools),
        InputKind("plant", PlantFile, "impeller-cam indexing-table plant (motion)",
                  _check_plant),
        InputKind("feed-drive", FeedDriveFile, "impeller-cam feed-drive parameters (motion)",
                  _check_feed_drive),
    )
}


def detect_kind(path: Path, data: dict[str, Any]) -> str:
    """The kind of a parsed TOML document: the kind whose top-level keys it uses most.

    Spec and design share their tables; a design's ``[camber.shroud]`` is a table.
    """
    keys = set(data)
    score = {name: len(keys & set(declared(kind.model))) for name, kind in KINDS.items()}
    best = max(score.values())
    if best == 0:
        raise InputError("cannot tell what kind of file this is", file=path,
                         value=sorted(keys)[:8],
                         accepted="a spec, design, machine, tool library, plant or "
                                  "feed-drive TOML (or give --kind)")
    names = [name for name, value in score.items() if value == best]
    if "spec" in names:
        camber = data.get("camber")
        line = camber.get("shroud") if isinstance(camber, dict) else None
        is_design = isinstance(line, dict) or (isinstance(camber, dict) and (
            "law" in camber or "points" in camber))
        return "design" if is_design or path.name.startswith("design") else "spec"
    if {"machine", "feed-drive"} <= set(names):
        axes = data.get("axes")
        tables = list(axes.values()) if isinstance(axes, dict) else []
        servo_only = all(isinstance(t, dict) and "Kpp" in t for t in tables) and tables
        return "feed-drive" if servo_only and "kinematics" not in data else "machine"
    return names[0]


def check_file(path: str | Path, kind: str | None = None) -> tuple[str, str]:
    """Validate one input file by its kind.

    Parameters
    ----------
    path : str or Path
    kind : str, optional
        One of ``KINDS`` (default: guessed from the content; ``.tbl``: tools).

    Returns
    -------
    kind, description : str
        The kind and a one-line description of what was read.

    Raises
    ------
    InputError
        The first problem in the file (file, field, value, what is accepted).
    """
    path = Path(path)
    if kind is not None and kind not in KINDS:
        raise InputError("unknown file kind", field="--kind", value=kind,
                         accepted=", ".join(KINDS))
    if kind is None:
        kind = "tools" if path.suffix == ".tbl" else detect_kind(path, load_toml(path, "input"))
    return kind, KINDS[kind].check(path)


def _spec_schema() -> dict[str, Any]:
    """The spec's schema, with the option tables of ``[machining]`` spelled out."""
    from cam.finishing.options import FinishOptions
    from cam.roughing.options import RoughOptions

    schema = json_schema(SpecFile, KINDS["spec"].title, "Impeller spec; docs/formats.md")
    table = schema["$defs"]["MachiningTable"]["properties"]
    for key, options in (("rough", RoughOptions), ("finish", FinishOptions)):
        inner = json_schema(options_model(options), key, f"{options.__name__} fields (mm, deg)")
        inner.pop("$schema")
        table[key] = inner
    return schema


def schemas() -> dict[str, dict[str, Any]]:
    """JSON Schema of every kind, by file name (``spec.schema.json``, ...)."""
    out = {}
    for name, kind in KINDS.items():
        schema = _spec_schema() if name == "spec" else json_schema(
            kind.model, kind.title, f"{kind.title}; docs/formats.md")
        out[f"{name}.schema.json"] = schema
    return out


def schema_text(schema: dict[str, Any]) -> str:
    """Deterministic JSON text of a schema (sorted keys, two-space indent)."""
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def write_schemas(folder: Path = SCHEMA_FOLDER) -> list[Path]:
    """Write every JSON Schema into ``folder``; return the paths."""
    from impeller_cam.atomic import write_text_atomic

    return [write_text_atomic(folder / name, schema_text(schema))
            for name, schema in schemas().items()]


if __name__ == "__main__":  # pragma: no cover
    for written in write_schemas(Path(sys.argv[1]) if len(sys.argv) > 1 else SCHEMA_FOLDER):
        print(written)
