"""The kinematics registry: name -> class, built-ins by decorator, others by entry point.

Built-in kinematics register themselves with ``@register_kinematics("xyzac-trt")``.
Third-party packages can add one through the entry-point group
``impeller_cam.kinematics`` (value: the class). A third-party kinematics whose import
fails stays listed and re-raises its original import error only when it is used.

A registered class is constructed with the ``Machine`` (``cls(machine)``) and must
carry the class attributes ``name`` and ``joint_names`` (e.g. ``("X", "Y", "Z", "A",
"C")``), which the machine loader uses to know which axes the TOML must describe.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import metadata
from typing import TYPE_CHECKING, Any, TypeVar

from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from postproc.kinematics.base import Kinematics
    from postproc.machine import Machine

#: Entry-point group for third-party kinematics.
ENTRY_POINT_GROUP = "impeller_cam.kinematics"

_T = TypeVar("_T", bound=type)
_REGISTRY: dict[str, Any] = {}
_ENTRY_POINTS_LOADED = False


class _BrokenKinematics:
    """Stands in for a plug-in whose import failed; re-raises that error when used."""

    joint_names: tuple[str, ...] = ()

    def __init__(self, name: str, error: BaseException) -> None:
        self.name = name
        self.error = error

    def __call__(self, machine: Machine) -> Any:
        raise self.error


def register_kinematics(name: str) -> Callable[[_T], _T]:
    """Class decorator: register a kinematics under ``name``.

    Parameters
    ----------
    name : str
        Registry key used in machine files (``kinematics = "xyzac-trt"``).

    Returns
    -------
    callable
        The decorator (returns the class unchanged).

    Raises
    ------
    ValueError
        When another class already holds ``name``.
    """

    def decorate(cls: _T) -> _T:
        held = _REGISTRY.get(name)
        if held is not None and held is not cls:
            raise ValueError(f"kinematics {name!r} is already registered by {held!r}")
        cls.name = name  # type: ignore[attr-defined]
        _REGISTRY[name] = cls
        return cls

    return decorate


def _load_entry_points() -> None:
    global _ENTRY_POINTS_LOADED
    if _ENTRY_POINTS_LOADED:
        return
    _ENTRY_POINTS_LOADED = True
    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name in _REGISTRY:
            continue
        try:
            _REGISTRY[entry.name] = entry.load()
        except Exception as error:  # noqa: BLE001 - any import failure of a plug-in
            _REGISTRY[entry.name] = _BrokenKinematics(entry.name, error)


def available_kinematics() -> list[str]:
    """Names of all registered kinematics, sorted.

    Returns
    -------
    list of str
    """
    _load_entry_points()
    return sorted(_REGISTRY)


def kinematics_class(name: str, file: str | Path | None = None) -> Any:
    """The class registered under ``name``.

    Parameters
    ----------
    name : str
        Registry key (``kinematics`` of a machine file).
    file : str or Path, optional
        The machine file, named in the error.

    Returns
    -------
    type
        The kinematics class (constructed with a ``Machine``).

    Raises
    ------
    InputError
        When no kinematics of that name is registered (names the accepted ones).
    """
    _load_entry_points()
    try:
        return _REGISTRY[name]
    except KeyError:
        raise InputError(
            "unknown kinematics",
            file=file,
            field="kinematics",
            value=name,
            accepted=", ".join(sorted(_REGISTRY)),
        ) from None


def joint_names_for(name: str, file: str | Path | None = None) -> tuple[str, ...]:
    """Joint names of the kinematics ``name``.

    Parameters
    ----------
    name : str
        Registry key.
    file : str or Path, optional
        The machine file, named in an error.

    Returns
    -------
    tuple of str
        E.g. ``("X", "Y", "Z", "A", "C")``.
    """
    cls = kinematics_class(name, file)
    if isinstance(cls, _BrokenKinematics):
        raise cls.error
    return tuple(cls.joint_names)


def kinematics_for(machine: Machine) -> Kinematics:
    """Construct the kinematics named by ``machine.kinematics`` for ``machine``.

    Parameters
    ----------
    machine : Machine
        The machine (pivot offsets mm, limits).

    Returns
    -------
    Kinematics
        Forward and inverse transforms between joints (mm, rad) and tool poses in W.
    """
    cls = kinematics_class(machine.kinematics, machine.source)
    instance: Kinematics = cls(machine)
    return instance
