"""Where stock and design come from: ``--stock`` and ``--design`` arguments.

``--stock`` accepts ``cylinder:D,H`` (mm; Z axis, from z = 0 up), an impeller spec
TOML (its lathe-turned blank), a closed mesh (``.stl``, ``.obj``, ``.ply``) or a saved
stock state (``.npz``). ``--design`` accepts an impeller spec TOML (its design mesh
from ``geometry``) or a closed mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cam.verify.stock import Stock
from geometry.blank import blank_profile, spec_blank_profile
from impeller_cam.errors import InputError

__all__ = ["blank_profile", "load_design", "load_stock", "spec_blank_profile"]

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off")
STOCK_ACCEPTED = (
    "cylinder:D,H (mm), an impeller spec .toml, a closed .stl/.obj/.ply mesh or a .npz state"
)


def _load_mesh(path: Path, field: str) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    import trimesh

    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as error:  # noqa: BLE001 - any reader failure is bad input
        raise InputError(f"cannot read the mesh: {error}", file=path, field=field) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("the file holds no triangle mesh", file=path, field=field)
    if not mesh.is_watertight:
        raise InputError(
            "the mesh is not closed (watertight)",
            file=path,
            field=field,
            accepted="a closed triangle mesh",
        )
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def load_stock(argument: str, resolution: float) -> Stock:
    """Build the stock named by a ``--stock`` argument at ray spacing ``resolution`` mm.

    A ``.npz`` state keeps its own resolution.
    """
    if argument.startswith("cylinder:"):
        parts = argument[len("cylinder:") :].split(",")
        try:
            diameter, height = (float(p) for p in parts)
        except ValueError:
            raise InputError(
                "a cylinder stock needs a diameter and a height",
                field="--stock",
                value=argument,
                accepted="cylinder:D,H, e.g. cylinder:80,40",
            ) from None
        return Stock.cylinder(diameter, height, resolution)
    path = Path(argument)
    if not path.is_file():
        raise InputError(
            "stock not found", field="--stock", value=argument, accepted=STOCK_ACCEPTED
        )
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return Stock.load(path)
    if suffix == ".toml":
        from geometry.spec import load_spec

        return Stock.revolved(spec_blank_profile(load_spec(path)), resolution)
    if suffix in MESH_SUFFIXES:
        vertices, faces = _load_mesh(path, "--stock")
        return Stock.from_mesh(vertices, faces, resolution)
    raise InputError("unknown stock kind", field="--stock", value=argument, accepted=STOCK_ACCEPTED)


def load_design(path: Path) -> tuple[NDArray[np.float64], NDArray[np.int64], float | None]:
    """Design mesh and finishing allowance (mm; ``None`` when the file has none).

    Raises
    ------
    InputError
        Missing file, unknown kind, or an open mesh.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("design not found", file=path, field="--design",
                         accepted="an impeller spec .toml or a closed .stl/.obj/.ply mesh")
    suffix = path.suffix.lower()
    if suffix in MESH_SUFFIXES:
        vertices, faces = _load_mesh(path, "--design")
        return vertices, faces, None
    if suffix == ".toml":
        from geometry.spec import load_spec

        spec = load_spec(path)
        try:
            from geometry.impeller import Impeller  # type: ignore[import-not-found]
        except ImportError as error:
            raise InputError(
                "this build has no impeller design mesh (geometry.impeller missing)",
                file=path,
                field="--design",
                accepted="a closed .stl design mesh",
            ) from error
        mesh = Impeller.from_spec(path).mesh()
        return (
            np.asarray(mesh.vertices, np.float64),
            np.asarray(mesh.faces, np.int64),
            float(spec.finishing_allowance),
        )
    raise InputError("unknown design kind", file=path, field="--design",
                     accepted="an impeller spec .toml or a closed .stl/.obj/.ply mesh")
