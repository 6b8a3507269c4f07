"""The optional ``[machining]`` table of an impeller spec: tools and job settings.

``impeller-cam run`` takes its tools and job settings from this table; command-line
options override it. The table is read and its *structure* validated here (known
keys, types, ranges); the option names of the ``rough`` and ``finish`` sub-tables are
checked against the roughing and finishing option dataclasses by ``cam.run.settings``
(geometry does not depend on cam). Format (docs/formats.md, docs/run.md)::

    [machining]
    rough_tool = "ball10"          # tool library name (or LIBRARY.toml:NAME)
    finish_tool = "ball6_taper"
    fillet_tool = "ball4_taper"    # optional: default the library's largest ball <= r_f
    post = "linuxcnc"              # optional: default the machine's dialect
    verify_resolution_mm = 0.2     # dexel spacing of the verification
    tessellation_mm = 0.02         # STL / render tessellation of the geometry stage

    [machining.rough]              # any RoughOptions field (mm, deg)
    scallop_mm = 0.5

    [machining.finish]             # any FinishOptions field (mm, deg)
    scallop_mm = 0.05
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator

from impeller_cam.schema import Strict, load_toml, quantity, validate

__all__ = ["MACHINING_KEYS", "MachiningSettings", "MachiningTable", "machining_of",
           "read_machining", "settings_of"]

#: Scalar keys of ``[machining]`` and what they accept.
MACHINING_KEYS: dict[str, str] = {
    "rough_tool": "a tool name, e.g. \"ball10\" (or LIBRARY.toml:NAME)",
    "finish_tool": "a tool name, e.g. \"ball6_taper\" (or LIBRARY.toml:NAME)",
    "fillet_tool": "a ball no larger than the fillet, e.g. \"ball4_taper\"",
    "post": "a post-processor name (impeller-cam posts)",
    "verify_resolution_mm": "a dexel spacing 0.005..5 mm",
    "tessellation_mm": "a linear deflection > 0 mm",
}
#: Sub-tables passed to the roughing / finishing options.
MACHINING_TABLES = ("rough", "finish")
#: Accepted verification resolution range, mm (that of ``impeller-cam verify``).
RESOLUTION_RANGE = (0.005, 5.0)


@dataclass(frozen=True)
class MachiningSettings:
    """Validated ``[machining]`` table (boundary units: mm, deg).

    Attributes
    ----------
    rough_tool, finish_tool : str or None
        Tool names (``None``: not given; the run then needs ``-t``).
    fillet_tool : str or None
        Ball of the fillet pencil passes (``None``: chosen from the library by the
        fillet radius, ``cam.finishing.fillet_plan.choose_fillet_tool``).
    post : str or None
        Post-processor name (``None``: the machine's).
    verify_resolution_mm : float or None
        Dexel spacing of the verification, mm.
    tessellation_mm : float or None
        Tessellation of the geometry stage's STL and render, mm.
    rough, finish : dict
        Keyword options of ``run_rough`` / ``run_finish`` (``RoughOptions`` /
        ``FinishOptions`` field names; checked by ``cam.run.settings``).
    """

    rough_tool: str | None = None
    finish_tool: str | None = None
    fillet_tool: str | None = None
    post: str | None = None
    verify_resolution_mm: float | None = None
    tessellation_mm: float | None = None
    rough: dict[str, Any] = field(default_factory=dict)
    finish: dict[str, Any] = field(default_factory=dict)


def _scalar(value: Any) -> Any:
    if isinstance(value, dict | list):
        raise ValueError("an option value must be a number, string or boolean")
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError("an option value must be finite")
    return value


Scalar = Annotated[Any, AfterValidator(_scalar)]


class MachiningTable(Strict):
    """Declaration of ``[machining]`` (``MACHINING_KEYS``; option sub-tables)."""

    rough_tool: str | None = quantity(None, min_length=1, description=MACHINING_KEYS["rough_tool"])
    finish_tool: str | None = quantity(None, min_length=1,
                                       description=MACHINING_KEYS["finish_tool"])
    fillet_tool: str | None = quantity(None, min_length=1,
                                       description=MACHINING_KEYS["fillet_tool"])
    post: str | None = quantity(None, min_length=1, description=MACHINING_KEYS["post"])
    verify_resolution_mm: float | None = quantity(
        None, unit="mm", ge=RESOLUTION_RANGE[0], le=RESOLUTION_RANGE[1],
        description="dexel spacing of the verification")
    tessellation_mm: float | None = quantity(None, unit="mm", ge=1e-4, le=10.0,
                                             description="linear deflection of STL / render")
    rough: dict[str, Scalar] | None = quantity(None, min_length=1,
                                               description="RoughOptions fields (mm, deg)")
    finish: dict[str, Scalar] | None = quantity(None, min_length=1,
                                                description="FinishOptions fields (mm, deg)")


def read_machining(data: dict[str, Any], path: Path | None = None) -> MachiningSettings:
    """Validate the ``[machining]`` table of parsed spec (or design) TOML ``data``.

    Parameters
    ----------
    data : dict
        The whole parsed TOML document.
    path : Path, optional
        The file, named in errors.

    Returns
    -------
    MachiningSettings
        Empty settings when the table is absent.

    Raises
    ------
    InputError
        Unknown key, wrong type or out-of-range value, naming file, field and value.
    """
    if "machining" not in data:
        return MachiningSettings()
    table = validate(_Document, {"machining": data["machining"]}, path).machining
    return settings_of(table)


class _Document(Strict):
    machining: MachiningTable


def settings_of(table: MachiningTable | None) -> MachiningSettings:
    """``MachiningSettings`` of a validated ``[machining]`` table (``None``: empty)."""
    if table is None:
        return MachiningSettings()
    return MachiningSettings(
        rough_tool=table.rough_tool,
        finish_tool=table.finish_tool,
        fillet_tool=table.fillet_tool,
        post=table.post,
        verify_resolution_mm=table.verify_resolution_mm,
        tessellation_mm=table.tessellation_mm,
        rough=dict(table.rough or {}),
        finish=dict(table.finish or {}),
    )


def machining_of(path: str | Path) -> MachiningSettings:
    """Read only the ``[machining]`` table of a spec file (no geometry validation)."""
    path = Path(path)
    return read_machining(load_toml(path, "spec"), path)
