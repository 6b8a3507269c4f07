"""The schema layer: strict declarations of input files and one message per problem.

Every file a user writes (spec, design, machine, tool library, motion plant, feed
drives) is declared once as a pydantic v2 model derived from ``Strict``: types,
units, ranges and defaults in one place, unknown keys refused (``extra="forbid"``),
no type coercion (``strict``), no NaN or infinity unless a field says so, no empty
table. ``validate`` turns the first problem into one ``InputError`` naming the file,
the table, the key, the value and what is accepted, with the nearest valid key when
an unknown key looks like a typo::

    tools.toml: field 'tool 'ball6_taper'.holdr': unknown key 'holdr' in [[tool]]
    'ball6_taper': did you mean 'holder'? ...

The same models give the JSON Schema of each file (``json_schema``), shipped in
``impeller_cam/schemas/`` (docs/formats.md).
"""

from __future__ import annotations

import difflib
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic.fields import FieldInfo
from pydantic.json_schema import GenerateJsonSchema, JsonSchemaValue
from pydantic_core import ErrorDetails

from impeller_cam.errors import InputError

__all__ = [
    "Strict",
    "declared",
    "json_schema",
    "load_toml",
    "quantity",
    "suggest",
    "validate",
]

M = TypeVar("M", bound=BaseModel)

#: Error types whose message names the expected type.
_TYPE_WORDS = {
    "float": "must be a number",
    "int": "must be an integer",
    "string": "must be a non-empty string",
    "bool": "must be true or false",
    "list": "must be a list",
    "tuple": "must be a list",
    "dict": "must be a table",
    "model": "must be a table",
    "literal": "unknown value",
}


class Strict(BaseModel):
    """Base of every input-file declaration: strict types, no unknown key, no NaN/inf.

    An empty table is refused too: it is a table whose keys were lost or mistyped.
    """

    model_config = ConfigDict(
        extra="forbid",
        strict=True,
        allow_inf_nan=False,
        frozen=True,
        populate_by_name=False,
        json_schema_extra={"minProperties": 1},
    )

    @model_validator(mode="before")
    @classmethod
    def _not_empty(cls, data: Any) -> Any:
        if isinstance(data, dict) and not data:
            raise ValueError("empty table")
        return data

    @classmethod
    def defaults(cls: type[M]) -> M:
        """An instance with every default (for an absent optional table)."""
        return cls.model_construct()


def quantity(
    default: Any = ...,
    *,
    unit: str | None = None,
    description: str = "",
    **constraints: Any,
) -> Any:
    """A ``pydantic.Field`` with its unit recorded in the JSON Schema.

    Parameters
    ----------
    default : Any
        Default value (``...``: required).
    unit : str, optional
        Unit in the file (``"mm"``, ``"deg"``, ``"mm/min"``, ...).
    description : str
        What the key means (shown by editors from the JSON Schema).
    **constraints
        ``gt``, ``ge``, ``lt``, ``le``, ``min_length``, ... as for ``Field``.
    """
    extra: dict[str, Any] | None = {"unit": unit} if unit else None
    text = f"{description} [{unit}]" if unit and description else description or None
    return Field(default, description=text, json_schema_extra=extra, **constraints)


def suggest(key: str, accepted: list[str]) -> str | None:
    """The accepted key nearest to ``key`` when it looks like a typo, else ``None``."""
    lower = {name.lower(): name for name in accepted}
    close = difflib.get_close_matches(key.lower(), list(lower), n=1, cutoff=0.6)
    return lower[close[0]] if close else None


def declared(model: type[BaseModel]) -> list[str]:
    """The keys a model accepts, in declaration order (aliases where given)."""
    return [info.alias or name for name, info in model.model_fields.items()]


def _unwrap(annotation: Any) -> list[Any]:
    """The types inside ``X | None``, ``list[X]``, ``dict[K, X]``, ``Annotated[X, ...]``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return [t for arg in typing.get_args(annotation) for t in _unwrap(arg)]
    if origin in (list, tuple, dict):
        args = typing.get_args(annotation)
        return _unwrap(args[-1]) if args else []
    return [annotation]


def _model_at(model: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model that validates the table at ``loc`` (a pydantic error location)."""
    current: type[BaseModel] | None = model
    for part in loc:
        if current is None:
            return None
        if not isinstance(part, str) or part not in current.model_fields:
            continue  # list index or dict key: stays on the same declared type
        inner = [t for t in _unwrap(current.model_fields[part].annotation)
                 if isinstance(t, type) and issubclass(t, BaseModel)]
        current = inner[0] if inner else None
    return current


def _node(data: Any, loc: tuple[Any, ...]) -> Any:
    """The value at ``loc`` in the parsed document (``None`` when absent)."""
    for part in loc:
        if isinstance(data, dict) and part in data:
            data = data[part]
        elif isinstance(data, list) and isinstance(part, int) and 0 <= part < len(data):
            data = data[part]
        else:
            return None
    return data


def _named(item: Any) -> str | None:
    name = item.get("name") if isinstance(item, dict) else None
    return name if isinstance(name, str) and name else None


def field_path(loc: tuple[Any, ...], data: Any) -> str:
    """Dotted key of ``loc``: ``tool 'ball10'.holder[0].length_mm``, ``axes.X.min``.

    Indices into a list of values (not of tables) at the end are left out: the key
    is ``meridional.hub``, the message says which entry.
    """
    while loc and isinstance(loc[-1], int):
        loc = loc[:-1]
    text = ""
    for i, part in enumerate(loc):
        if isinstance(part, int):
            name = _named(_node(data, loc[: i + 1]))
            text += f" {name!r}" if name else f"[{part}]"
        else:
            text += f".{part}" if text else str(part)
    return text


def table_label(loc: tuple[Any, ...], data: Any, root: str = "the top level") -> str:
    """How a table is named in a message: ``[blade]``, ``[[tool]] 'ball6_taper'``."""
    if not loc:
        return root
    keys = ".".join(str(p) for p in loc if isinstance(p, str))
    if not isinstance(loc[-1], int):
        return f"[{keys}]"
    label = f"[[{keys}]]"
    own = _named(_node(data, loc))
    if own:
        return f"{label} {own!r}"
    owner = next((n for i in range(len(loc) - 1, 0, -1)
                  if isinstance(loc[i - 1], int) and (n := _named(_node(data, loc[:i])))), None)
    return f"{label} {loc[-1]} of {owner!r}" if owner else f"{label} {loc[-1]}"


class _Shown(str):
    """A value shown as it is (a shortened repr) in an ``InputError``."""

    def __repr__(self) -> str:
        return str(self)


def _short(value: Any, limit: int = 70) -> Any:
    text = repr(value)
    if len(text) <= limit and not isinstance(value, dict | list):
        return value
    return _Shown(text if len(text) <= limit else text[: limit - 3] + "...")


def _range(info: FieldInfo) -> str:
    """``1..64``, ``> 0``, ``>= 0``, ``0.05..0.9`` from a field's declared bounds."""
    bound: dict[str, Any] = {}
    for item in info.metadata:
        for name in ("gt", "ge", "lt", "le"):
            if getattr(item, name, None) is not None:
                bound[name] = getattr(item, name)
    low = bound.get("ge", bound.get("gt"))
    high = bound.get("le", bound.get("lt"))
    if "ge" in bound and "le" in bound:
        return f"{low:g}..{high:g}"
    parts = [f"{op} {bound[name]:g}" for name, op in
             (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")) if name in bound]
    return " and ".join(parts)


def _accepted(error: ErrorDetails, model: type[BaseModel] | None, key: Any) -> str:
    """What would be accepted, from the field's declaration (type, bounds, unit)."""
    ctx = error.get("ctx") or {}
    kind = error["type"]
    if kind == "literal_error":
        return str(ctx.get("expected", ""))
    info = model.model_fields.get(key) if model is not None and isinstance(key, str) else None
    if info is None:
        return error["msg"].removeprefix("Input should be ")
    extra = info.json_schema_extra
    unit = f" {extra['unit']}" if isinstance(extra, dict) and extra.get("unit") else ""
    kinds = {t for t in _unwrap(info.annotation) if t is not type(None)}
    what = ("an integer" if kinds == {int} else "a finite number" if kinds <= {float, int}
            else "true or false" if kinds == {bool} else "a string" if kinds == {str}
            else None)
    if what is None:
        return error["msg"].removeprefix("Input should be ")
    span = _range(info)
    return f"{what} {span}{unit}".replace("  ", " ") if span else f"{what}{unit}"


def _message(
    error: ErrorDetails, model: type[BaseModel], data: Any, file: Any, root: str,
    noun: str = "key",
) -> InputError:
    loc = tuple(error["loc"])
    kind = error["type"]
    parent, key = loc[:-1], (loc[-1] if loc else None)
    where = table_label(parent, data, root)
    field = field_path(loc, data) or None
    value = error.get("input")
    if kind == "extra_forbidden":
        keys = declared(m) if (m := _model_at(model, parent)) else []
        near = suggest(str(key), keys)
        text = f"unknown {noun} {key!r}" + (f" in {where}" if parent or noun == "key" else "")
        text += f": did you mean {near!r}?" if near else ""
        return InputError(text, file=file, field=field, value=_short(value),
                          accepted=", ".join(keys) or None)
    if kind == "missing":
        owner = _model_at(model, parent)
        return InputError(f"{key!r} is required in {where}: the key is missing",
                          file=file, field=field, accepted=_accepted(error, owner, key))
    owner = _model_at(model, parent)
    if isinstance(key, int) or key == "[key]":
        owner = None
    if kind == "value_error":
        text = str((error.get("ctx") or {}).get("error", error["msg"]))
        if text == "empty table":
            return InputError(f"empty table {table_label(loc, data, root)}", file=file,
                              field=field, accepted="a table with at least one key")
        return InputError(text, file=file, field=field, value=_short(value),
                          accepted=None)
    if kind == "finite_number":
        text = "must be a finite number"
    elif kind in ("greater_than", "greater_than_equal"):
        bound = (error.get("ctx") or {}).get("gt", (error.get("ctx") or {}).get("ge"))
        positive = kind == "greater_than" and bound == 0
        text = ("must be positive" if positive else
                "must not be negative" if bound == 0 else "out of range")
    elif kind in ("less_than", "less_than_equal") or kind.startswith(("too_", "int_from")):
        text = "out of range" if not kind.startswith("too_") else "wrong number of entries"
    else:
        text = _TYPE_WORDS.get(kind.split("_")[0], error["msg"])
    if isinstance(value, float) and math.isnan(value):
        text = "must be a finite number"
    entries = [str(p) for p in loc if isinstance(p, int)]
    if isinstance(key, int) and not isinstance(_node(data, loc), dict):
        keys = [p for p in loc if isinstance(p, str)]
        where = f"entry {'.'.join(entries)} of {keys[-1] if keys else 'the list'}"
    return InputError(f"{text} in {where}", file=file, field=field, value=_short(value),
                      accepted=_accepted(error, owner, key))


def _first(errors: list[ErrorDetails]) -> ErrorDetails:
    """The error to report: an unknown key (a likely typo) before what it caused."""
    for error in errors:
        if error["type"] == "extra_forbidden":
            return error
    return errors[0]


def validate(
    model: type[M],
    data: Any,
    file: str | Path | None = None,
    at: tuple[str, ...] = (),
    root: str = "the top level",
    noun: str = "key",
) -> M:
    """Validate parsed ``data`` against ``model``; one ``InputError`` on the first problem.

    Parameters
    ----------
    model : type of Strict
        The declaration of the file (or table).
    data : Any
        The parsed TOML document (or table).
    file : str or Path, optional
        Named in the error.
    at : tuple of str
        Where ``data`` sits in its document when it is a table of it
        (``("axes", "X", "servo")``), for the field and table named in the error.
    root : str
        How the outermost table is called in messages.
    noun : str
        What an unknown top-level name is called (``"finishing option"``).

    Raises
    ------
    InputError
        Naming file, dotted field, value and what is accepted; for an unknown key the
        nearest valid one.
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        error = _first(exc.errors())
        if at:
            for key in reversed(at):
                data = {key: data}
            error = {**error, "loc": (*at, *error["loc"])}  # type: ignore[typeddict-item]
        raise _message(error, _wrap(model, at), data, file, root, noun) from None


def _wrap(model: type[BaseModel], at: tuple[str, ...]) -> type[BaseModel]:
    """A model holding ``model`` at the dotted place ``at`` (for messages only)."""
    from pydantic import create_model

    for key in reversed(at):
        fields: dict[str, Any] = {key: (model, ...)}
        model = create_model(f"At_{key}", __base__=Strict, **fields)
    return model


def load_toml(path: str | Path, kind: str) -> dict[str, Any]:
    """Parse a TOML file; a missing file or bad TOML is an ``InputError``.

    Parameters
    ----------
    path : str or Path
    kind : str
        What the file is, for the message (``"spec"``, ``"machine"``, ...).
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
        raise InputError(f"{kind} file not found", file=path, value=str(path),
                         accepted=f"an existing {kind} TOML file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read {kind} file: {error}", file=path) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None


class _TomlSchema(GenerateJsonSchema):
    """JSON Schema of a TOML file: TOML has no null, an optional key is just absent."""

    def nullable_schema(self, schema: Any) -> JsonSchemaValue:
        return self.generate_inner(schema["schema"])


def _no_null_defaults(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _no_null_defaults(v) for k, v in node.items()
                if not (k == "default" and v is None)}
    if isinstance(node, list):
        return [_no_null_defaults(v) for v in node]
    return node


def json_schema(model: type[BaseModel], title: str, describe: str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a file declared by ``model``."""
    schema = _no_null_defaults(model.model_json_schema(mode="validation",
                                                       schema_generator=_TomlSchema))
    schema["title"] = title
    schema["description"] = describe
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def with_file(error: InputError, file: str | Path, prefix: str = "") -> InputError:
    """``error`` again, naming ``file`` and the dotted ``prefix`` before its field."""
    field = error.field if not prefix else f"{prefix}.{error.field}" if error.field else prefix
    return InputError(error.message, file=file, field=field, value=error.value,
                      accepted=error.accepted)

