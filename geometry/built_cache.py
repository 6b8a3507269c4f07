"""The solids and meshes this process has built, kept for the next ``Impeller`` of
the same geometry.

The chain builds one design in four stages (geometry, roughing's design meshes, the
finish stage's rough verification and finishing, the verify stage's labelled
design): each ``Impeller.from_spec`` is a new object that built its solid and
meshed it again, the same solid and the same triangles every time (the build and the
tessellation are deterministic). Here the last ``SIZE`` geometries' solids and
meshes are kept, keyed by a digest of everything the solid is made from
(``geometry_key``), so a second ``Impeller`` of the same geometry takes them over.
Figures made from the spec alone that several stages ask for (the turned blank's
profile: 0.7-2.5 s, asked for by roughing twice, the finish stage's and the verify
stage's blank) are kept the same way (``derived``).

What is handed out is never changed by the code that receives it: the solid (OCC
shapes are shared handles; a tessellation cleans the faces' triangulation first,
``geometry.mesh.triangulate_faces``) and, per ``Impeller``, its own copy of each
mesh (the cache keeps a private copy), so a caller that changes its mesh changes
nothing of another's.
"""

from __future__ import annotations

import dataclasses
import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from geometry.assembly import ImpellerSolid
    from geometry.spec import ImpellerSpec

__all__ = ["SIZE", "BuiltGeometry", "clear", "derived", "geometry_key", "lookup", "store"]

#: Geometries kept (the most recently used): a chain needs one, a sweep's worker one
#: at a time.
SIZE = 2
#: Fields of ``ImpellerSpec`` the solid does not depend on.
_NOT_GEOMETRY = frozenset({"name", "source", "machining"})

_lock = threading.Lock()


class _Recent(OrderedDict):  # type: ignore[type-arg]
    """The ``size`` most recently used entries (under ``_lock``)."""

    def __init__(self, size: int) -> None:
        super().__init__()
        self.size = size

    def get_used(self, key: Any) -> Any:
        """The entry of ``key`` (now the most recently used), else None."""
        with _lock:
            found = self.get(key)
            if found is not None:
                self.move_to_end(key)
            return found

    def keep(self, key: Any, value: Any) -> Any:
        """Keep ``value`` (the oldest beyond ``size`` dropped); the one kept (an equal
        one another thread kept first wins)."""
        with _lock:
            kept = self.setdefault(key, value)
            self.move_to_end(key)
            while len(self) > self.size:
                self.popitem(last=False)
            return kept


#: Figures kept by ``derived``.
DERIVED_SIZE = 8
_kept = _Recent(SIZE)
#: Other figures of a spec (``derived``), by (geometry key, name).
_derived = _Recent(DERIVED_SIZE)


@dataclass
class BuiltGeometry:
    """A built solid, how long it took (s), and its meshes per tolerance (mm)."""

    solid: ImpellerSolid
    seconds: float
    meshes: dict[float, tuple[Any, np.ndarray]] = field(default_factory=dict)


def geometry_key(spec: ImpellerSpec, fillets: bool) -> str:
    """Digest of every field of ``spec`` the solid is built from, and ``fillets``.

    Parameters
    ----------
    spec : ImpellerSpec
    fillets : bool
        Whether the blade-to-hub fillets are built.

    Returns
    -------
    str
        Hex digest: equal for two specs that give the same solid.
    """
    digest = hashlib.blake2b(digest_size=20)
    digest.update(repr(bool(fillets)).encode())
    for item in dataclasses.fields(spec):
        if item.name in _NOT_GEOMETRY:
            continue
        value = getattr(spec, item.name)
        digest.update(item.name.encode())
        if isinstance(value, np.ndarray):
            array = np.ascontiguousarray(value)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        else:
            digest.update(repr(value).encode())
    return digest.hexdigest()


def lookup(key: str) -> BuiltGeometry | None:
    """The kept geometry of ``key`` (now the most recently used), else None."""
    found: BuiltGeometry | None = _kept.get_used(key)
    return found


def store(key: str, built: BuiltGeometry) -> BuiltGeometry:
    """Keep ``built`` under ``key`` (the oldest beyond ``SIZE`` dropped); the one kept
    (an equal one another thread stored first wins)."""
    kept: BuiltGeometry = _kept.keep(key, built)
    return kept


def derived(spec: ImpellerSpec, name: str, make: Callable[[], np.ndarray]) -> np.ndarray:
    """A figure of ``spec``'s geometry (an array), made once per geometry and name.

    Parameters
    ----------
    spec : ImpellerSpec
    name : str
        What the figure is (e.g. ``"blank_profile"``); ``make`` must depend on
        nothing but the fields ``geometry_key`` digests.
    make : callable
        Makes the figure.

    Returns
    -------
    numpy.ndarray
        A copy of the kept figure: the caller may change it.
    """
    key = (geometry_key(spec, True), name)
    found = _derived.get_used(key)
    if found is None:
        found = _derived.keep(key, np.array(make(), copy=True))
    return np.array(found, copy=True)


def clear() -> None:
    """Forget every kept geometry and figure (a benchmark timing builds, a test of a
    fresh one)."""
    with _lock:
        _kept.clear()
        _derived.clear()
