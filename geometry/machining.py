"""The optional ``[machining]`` table of an impeller spec: tools and job settings.

``impeller-cam run`` takes its tools and job settings from this table; command-line
options override it. The table is read and its *structure* validated here (known
keys, types, ranges); the option names of the ``rough`` and ``finish`` sub-tables are
checked against the roughing and finishing option dataclasses by ``cam.run.settings``
(geometry does not depend on cam). Format (docs/formats.md, docs/run.md)::

    [machining]
    rough_tool = "ball10"          # tool library name (or LIBRARY.toml:NAME)
    finish_tool = "ball6_taper"
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
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["MACHINING_KEYS", "MachiningSettings", "machining_of", "read_machining"]

#: Scalar keys of ``[machining]`` and what they accept.
MACHINING_KEYS: dict[str, str] = {
    "rough_tool": "a tool name, e.g. \"ball10\" (or LIBRARY.toml:NAME)",
    "finish_tool": "a tool name, e.g. \"ball6_taper\" (or LIBRARY.toml:NAME)",
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
    post: str | None = None
    verify_resolution_mm: float | None = None
    tessellation_mm: float | None = None
    rough: dict[str, Any] = field(default_factory=dict)
    finish: dict[str, Any] = field(default_factory=dict)


def _number(path: Path | None, key: str, value: Any, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or not low <= value <= high:
        raise InputError("out of range" if isinstance(value, int | float) else
                         "must be a number", file=path, field=f"machining.{key}",
                         value=value, accepted=MACHINING_KEYS[key])
    return float(value)


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
    table = data.get("machining")
    if table is None:
        return MachiningSettings()
    if not isinstance(table, dict):
        raise InputError("must be a table", file=path, field="machining", value=table,
                         accepted="a TOML table [machining]")
    accepted = ", ".join([*MACHINING_KEYS, *MACHINING_TABLES])
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key in MACHINING_TABLES:
            if not isinstance(value, dict):
                raise InputError("must be a table", file=path, field=f"machining.{key}",
                                 value=value, accepted=f"a table [machining.{key}]")
            for name, option in value.items():
                if isinstance(option, dict | list):
                    raise InputError("must be a number, string or boolean", file=path,
                                     field=f"machining.{key}.{name}", value=option,
                                     accepted="a scalar option value")
            values[key] = dict(value)
        elif key in ("rough_tool", "finish_tool", "post"):
            if not isinstance(value, str) or not value.strip():
                raise InputError("must be a non-empty string", file=path,
                                 field=f"machining.{key}", value=value,
                                 accepted=MACHINING_KEYS[key])
            values[key] = value
        elif key == "verify_resolution_mm":
            values[key] = _number(path, key, value, *RESOLUTION_RANGE)
        elif key == "tessellation_mm":
            values[key] = _number(path, key, value, 1e-4, 10.0)
        else:
            raise InputError("unknown key", file=path, field=f"machining.{key}", value=value,
                             accepted=accepted)
    return MachiningSettings(**values)


def machining_of(path: str | Path) -> MachiningSettings:
    """Read only the ``[machining]`` table of a spec file (no geometry validation)."""
    import tomllib

    path = Path(path)
    if not path.is_file():
        raise InputError("spec file not found", file=path, value=str(path),
                         accepted="an existing impeller spec TOML")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None
    return read_machining(data, path)
