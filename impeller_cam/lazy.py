"""Lazy front doors: a package's ``__init__`` names its public objects without importing
the modules that define them until one is used (PEP 562 module ``__getattr__``).

``impeller-cam --help`` imports the packages of every sub-command; importing
OpenCASCADE, numba kernels or build123d there would cost seconds. A front door
declares ``{name: module}`` and gets the ``__getattr__`` and ``__dir__`` of its module.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: Mapping[str, str]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Module ``__getattr__`` and ``__dir__`` resolving ``exports`` on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (for the error message).
    exports : mapping of str to str
        Public name -> the module that defines it (same name there), or
        ``"module:name"`` for an object exported under another name.

    Returns
    -------
    getattr : callable
        ``__getattr__(name)``: imports the module of ``name`` and returns the object.
    dir : callable
        ``__dir__()``: the exported names and the module's own.
    """

    def __getattr__(name: str) -> Any:
        where = exports.get(name)
        if where is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attribute = where.partition(":")
        return getattr(importlib.import_module(module), attribute or name)

    def __dir__() -> list[str]:
        return sorted(set(exports) | set(vars(sys.modules[package])))

    return __getattr__, __dir__
