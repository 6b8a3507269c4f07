"""The variants of a sweep: ``--vary`` parameters, cross product or Latin hypercube.

A ``--vary`` argument is ``PATH=VALUES``:

* ``PATH``: a dotted key of the design TOML, list elements by index, e.g. ``blades``
  (short for ``impeller.blades``), ``blade.thickness_mm``,
  ``camber.shroud.beta_deg[2]``, ``meridional.hub[1][0]``;
* ``VALUES``: a comma list (``7,9,11``, ``round,cut``) or a range ``START:STOP:COUNT``
  (``-34:-42:4``: four equally spaced values from -34 to -42, both ends included).

Numbers take the type of the value they replace: an integer key (``blades``) gets
integers (a range's values rounded), every other number a float. A path that is not
in the design is bad input (``InputError``, field ``--vary``); a value the design
generator refuses is not: that variant is recorded as invalid (``cam.run.sweep_task``).

``variants`` makes the designs: the cross product of the value lists (first
parameter slowest), or with ``samples`` a Latin hypercube of that many variants
(seeded): per parameter the unit interval is cut into ``samples`` strata, each
stratum used once in a random order and a uniform point drawn inside it; a range
maps the point onto ``[START, STOP]`` (continuous), a list onto its items
(``floor(u * len)``).
"""

from __future__ import annotations

import copy
import itertools
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from impeller_cam.errors import InputError

__all__ = ["Variant", "VaryParameter", "parse_vary", "set_path", "variants"]

#: Top-level keys of ``[impeller]`` that may be given without the table name.
SHORT_KEYS = {"blades": "impeller.blades"}
#: Decimals kept of a sampled or ranged float value.
DECIMALS = 6
_STEP = re.compile(r"([^.\[\]]+)|\[(-?\d+)\]")
_ACCEPTED_VARY = ("PATH=V1,V2,... or PATH=START:STOP:COUNT, PATH a dotted design key "
                  "(list items as [i]), e.g. blades=7,9,11 or camber.shroud.beta_deg[2]="
                  "-34:-42:4")


@dataclass(frozen=True)
class VaryParameter:
    """One varied design parameter.

    Attributes
    ----------
    path : str
        As given (after ``SHORT_KEYS``), the column name in sweep.csv.
    steps : tuple of (str or int)
        Keys and list indices from the design's root.
    values : tuple
        The values of the cross product (a range: its ``COUNT`` values).
    span : (float, float) or None
        ``(START, STOP)`` of a range (the Latin hypercube samples inside it).
    integer : bool
        The design holds an integer there.
    """

    path: str
    steps: tuple[str | int, ...]
    values: tuple[Any, ...]
    span: tuple[float, float] | None = None
    integer: bool = False


@dataclass(frozen=True)
class Variant:
    """A design of the sweep: its name, parameter values and the design dict."""

    name: str
    parameters: dict[str, Any]
    design: dict[str, Any]


def _steps(path: str) -> tuple[str | int, ...]:
    steps: list[str | int] = []
    pos = 0
    for match in _STEP.finditer(path):
        if match.start() != pos and path[pos:match.start()] != ".":
            break
        key, index = match.groups()
        steps.append(key if key is not None else int(index))
        pos = match.end()
    if pos != len(path) or not steps or not isinstance(steps[0], str):
        raise InputError("bad parameter path", field="--vary", value=path,
                         accepted=_ACCEPTED_VARY)
    return tuple(steps)


def _get(design: dict[str, Any], steps: tuple[str | int, ...], path: str) -> Any:
    node: Any = design
    for step in steps:
        ok = (isinstance(step, str) and isinstance(node, dict) and step in node) or (
            isinstance(step, int) and isinstance(node, list) and -len(node) <= step < len(node))
        if not ok:
            raise InputError("not a value of the design", field="--vary", value=path,
                             accepted="a key (and list index) the design TOML has")
        node = node[step]
    return node


def set_path(design: dict[str, Any], steps: tuple[str | int, ...], value: Any
             ) -> dict[str, Any]:
    """A deep copy of ``design`` with ``value`` at ``steps``."""
    out = copy.deepcopy(design)
    node: Any = out
    for step in steps[:-1]:
        node = node[step]
    node[steps[-1]] = value
    return out


def _number(text: str, integer: bool, path: str) -> int | float:
    try:
        value = float(text)
    except ValueError:
        raise InputError("not a number", field="--vary", value=f"{path}={text}",
                         accepted=_ACCEPTED_VARY) from None
    if integer and value == int(value):
        return int(value)
    return round(value, DECIMALS) + 0.0


def parse_vary(argument: str, design: dict[str, Any]) -> VaryParameter:
    """Parse one ``--vary PATH=VALUES`` against the base design dict.

    Raises
    ------
    InputError
        Bad syntax, a path the design does not have, a range that is not numeric or
        has a count below 1.
    """
    path, sep, values = argument.partition("=")
    path, values = path.strip(), values.strip()
    if not sep or not path or not values:
        raise InputError("bad --vary argument", field="--vary", value=argument,
                         accepted=_ACCEPTED_VARY)
    path = SHORT_KEYS.get(path, path)
    steps = _steps(path)
    current = _get(design, steps, path)
    integer = isinstance(current, int) and not isinstance(current, bool)
    if isinstance(current, dict | list):
        raise InputError("the path names a table or list, not a value", field="--vary",
                         value=path, accepted="a path down to one value ([i] for items)")
    parts = values.split(":")
    if len(parts) == 3 and "," not in values:
        start, stop = (_number(p, False, path) for p in parts[:2])
        count = _number(parts[2], True, path)
        if not isinstance(count, int) or count < 1:
            raise InputError("a range needs a whole COUNT >= 1", field="--vary",
                             value=argument, accepted=_ACCEPTED_VARY)
        grid = [start] if count == 1 else np.linspace(start, stop, count).tolist()
        cast = [int(round(x)) if integer else round(float(x), DECIMALS) + 0.0 for x in grid]
        return VaryParameter(path, steps, tuple(cast), (float(start), float(stop)), integer)
    items = [v.strip() for v in values.split(",")]
    if any(not v for v in items):
        raise InputError("empty value in the list", field="--vary", value=argument,
                         accepted=_ACCEPTED_VARY)
    if isinstance(current, str):
        return VaryParameter(path, steps, tuple(items))
    if isinstance(current, bool):
        flags = {"true": True, "false": False}
        if any(v.lower() not in flags for v in items):
            raise InputError("not true or false", field="--vary", value=argument,
                             accepted="true, false")
        return VaryParameter(path, steps, tuple(flags[v.lower()] for v in items))
    return VaryParameter(path, steps, tuple(_number(v, integer, path) for v in items),
                         integer=integer)


def _lhs_values(parameters: list[VaryParameter], samples: int, seed: int
                ) -> list[list[Any]]:
    """Latin hypercube: ``samples`` rows of one value per parameter."""
    rng = np.random.default_rng(seed)
    columns = []
    for p in parameters:
        u = (rng.permutation(samples) + rng.random(samples)) / samples
        if p.span is not None:
            a, b = p.span
            x = a + u * (b - a)
            columns.append([int(round(v)) if p.integer else round(float(v), DECIMALS) + 0.0
                            for v in x])
        else:
            idx = np.minimum((u * len(p.values)).astype(int), len(p.values) - 1)
            columns.append([p.values[i] for i in idx])
    return [list(row) for row in zip(*columns, strict=True)]


def variants(design: dict[str, Any], parameters: list[VaryParameter], base: str,
             samples: int | None = None, seed: int = 0) -> list[Variant]:
    """The sweep's designs, named ``<base>_<index>`` (3 digits), in order.

    Parameters
    ----------
    design : dict
        The base design TOML as a dict (left unchanged).
    parameters : list of VaryParameter
        Distinct paths (``InputError`` otherwise).
    base : str
        Name prefix (the base design's impeller name).
    samples : int, optional
        Latin hypercube of this many variants (>= 1); default the cross product.
    seed : int
        Seed of the Latin hypercube.
    """
    paths = [p.path for p in parameters]
    if len(set(paths)) != len(paths):
        raise InputError("a parameter is varied twice", field="--vary",
                         value=sorted({p for p in paths if paths.count(p) > 1})[0],
                         accepted="each path once")
    if samples is not None and samples < 1:
        raise InputError("must be >= 1", field="--samples", value=samples,
                         accepted="a number of Latin hypercube samples")
    if samples is not None:
        rows = _lhs_values(parameters, samples, seed)
    else:
        rows = [list(r) for r in itertools.product(*(p.values for p in parameters))]
    out = []
    width = max(3, len(str(len(rows) - 1)))
    for index, row in enumerate(rows):
        name = f"{base}_{index:0{width}d}"
        variant = set_path(design, ("impeller", "name"), name)
        for p, value in zip(parameters, row, strict=True):
            variant = set_path(variant, p.steps, value)
        out.append(Variant(name, dict(zip(paths, row, strict=True)), variant))
    return out
