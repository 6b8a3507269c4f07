"""The scene's meshes as fcl objects, by role and in role order, each built on first use.

``CollisionScene`` (``cam.collision.scene``) hands these to fcl only for the pairs its
own phases leave undecided, so most roles never build an fcl BVH.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import overload

import fcl
import numpy as np
import trimesh

from cam.collision.tool_mesh import bvh_model
from impeller_cam.errors import InputError

__all__ = ["InOrder", "RoleObjects", "check_meshes"]


class RoleObjects(Mapping[str, fcl.CollisionObject]):
    """fcl objects of the scene meshes by role, each built on first access."""

    def __init__(self, meshes: Mapping[str, trimesh.Trimesh]) -> None:
        self._meshes = meshes
        self._built: dict[str, fcl.CollisionObject] = {}

    def __getitem__(self, role: str) -> fcl.CollisionObject:
        if role not in self._built:
            mesh = self._meshes[role]
            self._built[role] = fcl.CollisionObject(bvh_model(mesh.vertices, mesh.faces),
                                                    fcl.Transform())
        return self._built[role]

    @property
    def built(self) -> list[str]:
        """The roles whose objects are built."""
        return list(self._built)

    def __iter__(self) -> Iterator[str]:
        return iter(self._meshes)

    def __len__(self) -> int:
        return len(self._meshes)


class InOrder(Sequence[fcl.CollisionObject]):
    """The role objects as a sequence in role order (built on access)."""

    def __init__(self, objects: RoleObjects, roles: tuple[str, ...]) -> None:
        self._objects, self._roles = objects, roles

    @overload
    def __getitem__(self, i: int) -> fcl.CollisionObject: ...

    @overload
    def __getitem__(self, i: slice) -> Sequence[fcl.CollisionObject]: ...

    def __getitem__(self, i: int | slice) -> fcl.CollisionObject | Sequence[fcl.CollisionObject]:
        if isinstance(i, slice):
            return [self._objects[r] for r in self._roles[i]]
        return self._objects[self._roles[i]]

    def __len__(self) -> int:
        return len(self._roles)


def check_meshes(meshes: Mapping[str, trimesh.Trimesh]) -> None:
    """Raise ``InputError`` unless ``meshes`` are non-empty trimeshes with finite vertices."""
    if not meshes:
        raise InputError("the collision scene needs at least one mesh", field="meshes")
    for role, mesh in meshes.items():
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError(
                "scene mesh must be a non-empty trimesh.Trimesh",
                field=f"meshes[{role!r}]",
                value=type(mesh).__name__,
            )
        if not np.isfinite(mesh.vertices).all():
            raise InputError("scene mesh has non-finite vertices", field=f"meshes[{role!r}]")
