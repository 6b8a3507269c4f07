"""The ``Impeller`` facade: spec -> surfaces -> solid (lazy, cached) -> meshes, export."""

from __future__ import annotations

import time
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from OCP.TopoDS import TopoDS_Face, TopoDS_Solid

from geometry import built_cache
from geometry.assembly import ROLES, ImpellerSolid, build_impeller_solid
from geometry.brep import area, bounding_box, volume
from geometry.export import write_step, write_stl
from geometry.fillet import fold_ratio
from geometry.mesh import tessellate
from geometry.spec import ImpellerSpec, load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES

__all__ = ["Impeller"]


class Impeller:
    """An impeller built from a validated spec.

    Parameters
    ----------
    spec : ImpellerSpec
        The validated spec (``geometry.spec.load_spec``).
    fillets : bool
        Build the blade-to-hub fillets (default). ``False`` explicitly asks for a
        solid without them.
    """

    def __init__(self, spec: ImpellerSpec, fillets: bool = True) -> None:
        self.spec = spec
        self.fillets = fillets
        self.build_seconds = 0.0
        self._meshes: dict[float, tuple[trimesh.Trimesh, np.ndarray]] = {}

    @classmethod
    def from_spec(cls, path: str | Path, fillets: bool = True) -> Impeller:
        """Load and validate a spec TOML.

        Parameters
        ----------
        path : str or Path
            The impeller spec TOML (docs/formats.md).
        fillets : bool
            Build the blade-to-hub fillets (default).

        Returns
        -------
        Impeller
            Not built yet: the surfaces and the solid are built on first use.
        """
        return cls(load_spec(path), fillets=fillets)

    @cached_property
    def surfaces(self) -> ImpellerSurfaces:
        """Closed-form surfaces (M1)."""
        return build_surfaces(self.spec)

    @cached_property
    def _kept(self) -> built_cache.BuiltGeometry:
        """This geometry's solid and meshes: built here, or taken over from an earlier
        ``Impeller`` of the same geometry in this process (``geometry.built_cache``)."""
        key = built_cache.geometry_key(self.spec, self.fillets)
        found = built_cache.lookup(key)
        if found is None:
            start = time.perf_counter()
            result = build_impeller_solid(self.surfaces, fillets=self.fillets)
            found = built_cache.store(
                key, built_cache.BuiltGeometry(result, time.perf_counter() - start))
        return found

    @cached_property
    def built(self) -> ImpellerSolid:
        """The fused solid with roles (built on first use; ``build_seconds`` is the
        build's time, also when an earlier ``Impeller`` of this geometry built it)."""
        kept = self._kept
        self.build_seconds = kept.seconds
        return kept.solid

    @property
    def solid(self) -> TopoDS_Solid:
        """The one valid OCP solid."""
        return self.built.part.solid

    def faces(self, role: str) -> list[TopoDS_Face]:
        """Faces of the solid with ``role``.

        Parameters
        ----------
        role : str
            One of ``geometry.assembly.ROLES``.

        Returns
        -------
        list of TopoDS_Face
            The OCP faces of that role (mm).
        """
        if role not in ROLES:
            raise InputError("unknown face role", field="role", value=role,
                             accepted=", ".join(ROLES))
        part = self.built.part
        return [f for f, r in zip(part.faces, part.roles, strict=True) if r == role]

    def role_counts(self) -> dict[str, int]:
        """Number of faces per role.

        Returns
        -------
        dict
            Role (every one of ``geometry.assembly.ROLES``) -> face count.
        """
        return {role: self.built.part.roles.count(role) for role in ROLES}

    def _mesh(self, tolerance: float) -> tuple[trimesh.Trimesh, np.ndarray]:
        if tolerance not in self._meshes:
            part = self.built.part
            shared = self._kept.meshes
            if tolerance not in shared:  # the kept copy is never handed out
                made = tessellate(part.solid, part.faces, part.roles, tolerance,
                                  DEFAULT_TOLERANCES.tessellation_angle)
                shared.setdefault(tolerance, (made[0].copy(), made[1].copy()))
                self._meshes[tolerance] = made
            else:
                mesh, labels = shared[tolerance]
                self._meshes[tolerance] = (mesh.copy(), labels.copy())
        return self._meshes[tolerance]

    def mesh(self, role: str | None = None,
             tolerance: float = DEFAULT_TOLERANCES.tessellation) -> trimesh.Trimesh:
        """Triangle mesh of the whole impeller (watertight) or of the faces of ``role``.

        Parameters
        ----------
        role : str, optional
            One of ``geometry.assembly.ROLES``; default the whole impeller.
        tolerance : float
            Chordal tolerance of the tessellation, mm (> 0).

        Returns
        -------
        trimesh.Trimesh
            Vertices in mm; cached per tolerance.
        """
        if tolerance <= 0:
            raise InputError("tessellation tolerance must be positive", field="tessellation",
                             value=tolerance, accepted="a length > 0 mm")
        whole, labels = self._mesh(tolerance)
        if role is None:
            return whole
        if role not in ROLES:
            raise InputError("unknown face role", field="role", value=role,
                             accepted=", ".join(ROLES))
        sub = whole.submesh([np.flatnonzero(labels == role)], append=True)
        return sub if isinstance(sub, trimesh.Trimesh) else trimesh.Trimesh()

    def triangle_roles(self, tolerance: float = DEFAULT_TOLERANCES.tessellation) -> np.ndarray:
        """Role of each triangle of :meth:`mesh` (whole) at ``tolerance``.

        Parameters
        ----------
        tolerance : float
            Chordal tolerance of the tessellation, mm.

        Returns
        -------
        (n_triangles,) str array
        """
        return self._mesh(tolerance)[1]

    def export_step(self, path: str | Path) -> Path:
        """Write the solid as STEP (AP214, mm; atomic, deterministic bytes).

        Parameters
        ----------
        path : str or Path
            The STEP file.

        Returns
        -------
        Path
            ``path``.
        """
        return write_step(self.solid, path)

    def export_stl(self, path: str | Path,
                   tolerance: float = DEFAULT_TOLERANCES.tessellation) -> Path:
        """Write the whole mesh as binary STL (mm).

        Parameters
        ----------
        path : str or Path
            The STL file.
        tolerance : float
            Chordal tolerance of the tessellation, mm.

        Returns
        -------
        Path
            ``path``.
        """
        return write_stl(self.mesh(tolerance=tolerance), path)

    @cached_property
    def figures(self) -> dict[str, Any]:
        """Derived figures: compute_figures (when available) + volume, area, bbox."""
        out: dict[str, Any] = {}
        try:
            from geometry.figures import compute_figures
        except ImportError:  # the figures module is another engineer's; optional here
            compute_figures = None  # type: ignore[assignment]
        if compute_figures is not None:
            fig = compute_figures(self.surfaces)
            out.update(
                d_min_mm=float(fig.d_min),
                d_min_points_mm=np.asarray(fig.d_min_points).tolist(),
                r_max_mm=float(fig.r_max),
                k=float(fig.k),
                min_thickness_mm=float(fig.min_thickness),
                rule_deviation_mm=float(fig.rule_deviation),
                max_fillet_radius_mm=float(fig.max_fillet_radius),
            )
        box = bounding_box(self.solid)  # the optimal box, B-spline faces only as needed
        out.update(
            blades=self.spec.blades,
            splitters=self.spec.splitters * self.spec.blades,
            fillet_radius_mm=self.spec.fillet_radius,
            fillets_built=self.fillets and self.spec.fillet_radius > 0,
            fillet_fold_ratio=max((fold_ratio(t, self.built.radius) for ts in self.built.tracks
                                   for t in ts), default=0.0),
            volume_mm3=volume(self.solid),
            area_mm2=area(self.solid),
            bbox_mm=box.tolist(),
        )
        return out
