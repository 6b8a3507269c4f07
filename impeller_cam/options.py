"""Options dataclasses built from keyword options, refusing unknown names.

The option tables (``[machining.rough]``, ``[machining.finish]``, the keyword options
of ``run_rough`` / ``run_finish``) are declared by their frozen dataclasses;
``options_model`` derives the strict schema of a dataclass from its fields (types
and defaults), so a table is checked for unknown keys (with the nearest valid one),
types and NaN/inf before the dataclass checks its ranges.
"""

from __future__ import annotations

import functools
import typing
from dataclasses import MISSING, fields
from typing import Any, TypeVar

from pydantic import BaseModel, create_model

from impeller_cam.schema import Strict, validate

T = TypeVar("T")


@functools.cache
def options_model(cls: type) -> type[BaseModel]:
    """The strict schema of the options dataclass ``cls`` (types and defaults)."""
    hints = typing.get_type_hints(cls)
    spec: dict[str, Any] = {}
    for item in fields(cls):
        default = item.default if item.default is not MISSING else ...
        spec[item.name] = (hints[item.name], default)
    return create_model(f"{cls.__name__}Table", __base__=Strict, __doc__=cls.__doc__,
                        **spec)


def options_from_mapping(cls: type[T], values: dict[str, Any], what: str) -> T:
    """Build the options dataclass ``cls`` from ``values``.

    Raises
    ------
    InputError
        Naming the first unknown option (and the nearest valid name), a wrong type
        or a NaN; the dataclass itself refuses out-of-range values.
    """
    if values:
        model = options_model(cls)  # type: ignore[arg-type]
        validate(model, dict(values), root=f"the {what} options", noun=f"{what} option")
    return cls(**values)
