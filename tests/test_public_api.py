"""The public API: every name in a package front door's ``__all__`` resolves and has a
numpy-style docstring (issue 24).

For each function, each class and each public method a class defines itself:

* a docstring;
* a ``Parameters`` section when it takes parameters (besides ``self``/``cls``; for a
  class: those of ``__init__``, or an ``Attributes`` section for a dataclass), naming
  every parameter;
* a ``Returns`` (or ``Yields``) section when its return annotation is not ``None``
  (properties and dunder methods excepted);
* a unit in the description of every parameter that is a length (``tolerance``,
  ``radius``, ``resolution``...) and does not carry its unit in its name
  (``scallop_mm``, ``entry_angle_deg`` do): ``mm``, ``deg``, ``rad`` or ``s``.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
from collections.abc import Callable, Iterator
from typing import Any

import pytest

#: Every package front door with an ``__all__``.
FRONT_DOORS = ("geometry", "cam", "cam.roughing", "cam.finishing", "cam.verify", "cam.motion",
               "postproc",
               "cam.run", "cam.report", "cam.collision", "postproc.kinematics",
               "postproc.posts", "impeller_cam")

#: Parameter names that carry a unit: their description must name it.
UNIT_NAMES = re.compile(r"^(tolerance|resolution|radius|diameter|deflection|allowance|"
                        r"pitch|spacing|length|height|depth|clearance|bore)$")
UNIT_WORDS = re.compile(r"\b(mm|mm\^?[23]|deg|degrees?|rad|radians?|s|seconds?|mm/min)\b")
SECTION = re.compile(r"^\s*(Parameters|Returns|Yields|Attributes|Raises|Notes|Examples|"
                     r"See Also|Other Parameters)\n\s*-{3,}\s*$", re.MULTILINE)


def _sections(doc: str) -> dict[str, str]:
    """Section name -> its text."""
    marks = list(SECTION.finditer(doc))
    return {m.group(1): doc[m.end():marks[i + 1].start() if i + 1 < len(marks) else None]
            for i, m in enumerate(marks)}


def _documented(section: str) -> dict[str, str]:
    """Parameter name -> its description, from a Parameters/Attributes section
    (``a, b : type`` documents both)."""
    out: dict[str, str] = {}
    current: list[str] = []
    for line in section.splitlines():
        head = re.match(r"^\s{0,4}(\*{0,2}[A-Za-z_][\w, *]*?)\s*(:.*)?$", line)
        if head and not line.startswith(" " * 5) and line.strip():
            current = [n.strip().lstrip("*") for n in head.group(1).split(",")]
            for name in current:
                out[name] = head.group(2) or ""
        else:
            for name in current:
                out[name] += " " + line.strip()
    return out


def _parameters(function: Callable[..., Any]) -> list[str]:
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):
        return []
    return [p.name for p in signature.parameters.values() if p.name not in ("self", "cls")]


def _returns_value(function: Callable[..., Any]) -> bool:
    try:
        annotation = inspect.signature(function).return_annotation
    except (TypeError, ValueError):
        return False
    return annotation not in (None, "None", inspect.Signature.empty)


def _problems(name: str, obj: Any, doc_of: Any | None = None) -> Iterator[str]:
    doc = inspect.getdoc(doc_of if doc_of is not None else obj)
    if not doc:
        yield f"{name}: no docstring"
        return
    sections = _sections(doc)
    if inspect.isclass(obj):
        if dataclasses.is_dataclass(obj):
            params = [f.name for f in dataclasses.fields(obj) if f.init]
            documented = _documented(sections.get("Attributes", "")
                                     + sections.get("Parameters", ""))
        else:
            own_init = "__init__" in vars(obj) and not getattr(obj, "_is_protocol", False)
            params = _parameters(obj.__init__) if own_init else []
            documented = _documented(sections.get("Parameters", "")
                                     + sections.get("Attributes", ""))
        for param in params:
            if param not in documented:
                yield f"{name}: parameter {param!r} not in Parameters/Attributes"
        yield from _units(name, params, documented)
        return
    params = [p for p in _parameters(obj) if not p.startswith("_")]
    documented = _documented(sections.get("Parameters", ""))
    for param in params:
        if param not in documented:
            yield f"{name}: parameter {param!r} not in Parameters"
    if _returns_value(obj) and not ({"Returns", "Yields"} & set(sections)):
        yield f"{name}: no Returns section"
    yield from _units(name, params, documented)


def _units(name: str, params: list[str], documented: dict[str, str]) -> Iterator[str]:
    for param in params:
        described = documented.get(param, "")
        if re.match(r"\s*:\s*bool\b", described):
            continue  # e.g. ``clearance : bool``: a switch, not a length
        if UNIT_NAMES.search(param) and param in documented and not UNIT_WORDS.search(
                described):
            yield f"{name}: parameter {param!r} has no unit (mm, deg, rad, s)"


def _public() -> Iterator[tuple[str, Any]]:
    for door in FRONT_DOORS:
        module = importlib.import_module(door)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{door}.{attr}", obj


def test_front_doors_resolve() -> None:
    for door in FRONT_DOORS:
        module = importlib.import_module(door)
        for attr in module.__all__:
            assert getattr(module, attr) is not None, f"{door}.{attr}"
        assert set(module.__all__) <= set(dir(module))


@pytest.mark.parametrize("door", FRONT_DOORS)
def test_docstrings(door: str) -> None:
    problems: list[str] = []
    seen: set[int] = set()
    for name, obj in _public():
        if not name.startswith(door + ".") or name.count(".") != door.count(".") + 1:
            continue
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        problems += _problems(name, obj)
        if inspect.isclass(obj) and not issubclass(obj, BaseException):
            for attr, member in vars(obj).items():
                if attr.startswith("_") or isinstance(member, property):
                    continue
                function = member.__func__ if isinstance(member, classmethod | staticmethod) \
                    else member
                if inspect.isfunction(function):
                    problems += _problems(f"{name}.{attr}", function)
    assert not problems, "\n".join(problems)
