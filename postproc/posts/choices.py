"""Dialect options: what a control offers (``TRAORI`` vectors, ``CYCLE800``, ``M128``...).

A dialect declares its options as ``DialectOption`` entries (``options`` class
attribute); ``impeller-cam posts`` lists them. The values come from the machine file
(``[control.options]``, applied when the machine's control is that dialect) and from
the command line (``--post-option KEY=VALUE``, which wins). ``resolve_dialect_options``
checks keys and values (an unknown key names the nearest valid one) and then asks
the dialect whether the combination is possible on the machine (``check_options``):
tool-direction vectors without tool-centre-point control, for example, are refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError
from impeller_cam.schema import suggest


@dataclass(frozen=True)
class DialectOption:
    """One option of a dialect.

    Attributes
    ----------
    name : str
        Key (``orientation``).
    choices : tuple of str
        Accepted values, the first is the default.
    description : str
        One line for ``impeller-cam posts``.
    """

    name: str
    choices: tuple[str, ...]
    description: str

    @property
    def default(self) -> str:
        """The default value (the first choice)."""
        return self.choices[0]


def declared_options(post: Any) -> tuple[DialectOption, ...]:
    """The options a dialect declares (none for a plug-in that declares nothing)."""
    return tuple(getattr(post, "options", ()))


def parse_option_words(words: list[str] | tuple[str, ...]) -> dict[str, str]:
    """``["orientation=vector", ...]`` (the CLI's ``--post-option``) -> a mapping.

    Raises
    ------
    InputError
        A word without ``=`` or with an empty key or value.
    """
    out: dict[str, str] = {}
    for word in words:
        key, sep, value = word.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise InputError("a post option is KEY=VALUE", field="--post-option", value=word,
                             accepted="KEY=VALUE, e.g. orientation=vector")
        out[key.strip()] = value.strip()
    return out


def resolve_dialect_options(
    post: Any,
    given: Mapping[str, object],
    *,
    source: str | Path | None = None,
    field_prefix: str = "--post-option",
) -> dict[str, str]:
    """Check ``given`` against the dialect's declared options; fill in the defaults.

    Parameters
    ----------
    post : PostProcessor
        The dialect.
    given : mapping of str to object
        Values from the machine file and the command line (``True``/``False`` are
        read as ``on``/``off``).
    source : str or Path, optional
        File named in errors (the machine file), None for the command line.
    field_prefix : str
        How the key is named in errors (``control.options`` or ``--post-option``).

    Returns
    -------
    dict of str to str
        Every declared option with its value.

    Raises
    ------
    InputError
        An unknown key (with the nearest valid key) or a value not among the choices.
    """
    declared = {option.name: option for option in declared_options(post)}
    resolved = {name: option.default for name, option in declared.items()}
    for key, raw in given.items():
        value = ("on" if raw else "off") if isinstance(raw, bool) else str(raw)
        option = declared.get(key)
        if option is None:
            near = suggest(key, list(declared))
            hint = f": did you mean {near!r}?" if near else ""
            accepted = ", ".join(sorted(declared)) or "none (this dialect has no options)"
            raise InputError(f"the {post.name} post has no option {key!r}{hint}", file=source,
                             field=f"{field_prefix}.{key}" if source else field_prefix,
                             value=key, accepted=accepted)
        if value not in option.choices:
            raise InputError(f"option {key!r} of the {post.name} post cannot be {value!r}",
                             file=source,
                             field=f"{field_prefix}.{key}" if source else field_prefix,
                             value=value, accepted=", ".join(option.choices))
        resolved[key] = value
    return resolved


def options_for_machine(post: Any, machine: Any,
                        given: Mapping[str, object] | None = None) -> dict[str, str]:
    """The dialect options of a posting run: the machine's, then ``given`` over them.

    The machine file's ``[control.options]`` apply when ``post`` is the machine's own
    dialect (``[control] dialect`` or ``post``); ``given`` (the command line) wins.
    Both are checked (``resolve_dialect_options``).
    """
    merged: dict[str, object] = {}
    if post.name == machine.post and machine.control_options:
        resolve_dialect_options(post, machine.control_options, source=machine.source,
                                field_prefix="control.options")
        merged.update(machine.control_options)
    if given:
        resolve_dialect_options(post, given)
        merged.update(given)
    return resolve_dialect_options(post, merged)
