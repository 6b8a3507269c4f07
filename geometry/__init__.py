"""Impeller geometry: camber data, parametric design, ruled surfaces, solids, meshes.

The front door of the package for geometry scripts (imports are lazy: OpenCASCADE and
build123d load on first use)::

    from geometry import Impeller, FaceRoles, impeller_part

    impeller = Impeller.from_spec("fixtures/impellers/small/spec.toml")
    print(impeller.figures["d_min_mm"], impeller.figures["volume_mm3"])
    impeller.export_step("small.step")
    part = impeller_part(impeller)                 # build123d Part
    pressure = FaceRoles.of(impeller).select(part, "pressure")

* spec and design: ``load_spec``, ``ImpellerSpec``; the design generator
  ``DesignParameters``, ``load_design``, ``generate``, ``write_design``;
* surfaces, solid, meshes: ``build_surfaces``, ``Impeller`` (solid, faces per role,
  meshes, STEP/STL export, figures), ``ROLES``; ``compute_figures``;
* files: ``read_step``, ``write_step``, ``write_stl``;
* the blank: ``spec_blank_profile``;
* build123d and cadquery (``geometry.interop``, ``geometry.meridional``):
  ``impeller_part``, ``impeller_workplane``, ``FaceRoles``, ``occ_shape``,
  ``solid_mesh``, ``meridional_profile``, ``hub_contour``, ``with_hub``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from geometry.assembly import ROLES
    from geometry.blank import spec_blank_profile
    from geometry.design import DesignParameters, generate, load_design
    from geometry.design_files import write_design
    from geometry.export import read_step, write_step, write_stl
    from geometry.figures import GeometryFigures, compute_figures
    from geometry.impeller import Impeller
    from geometry.interop import (
        FaceRoles,
        impeller_part,
        impeller_workplane,
        occ_shape,
        solid_mesh,
    )
    from geometry.meridional import hub_contour, meridional_profile, with_hub
    from geometry.spec import ImpellerSpec, load_spec
    from geometry.surfaces import ImpellerSurfaces, build_surfaces

_EXPORTS = {
    "ROLES": "geometry.assembly",
    "spec_blank_profile": "geometry.blank",
    "DesignParameters": "geometry.design",
    "generate": "geometry.design",
    "load_design": "geometry.design",
    "write_design": "geometry.design_files",
    "read_step": "geometry.export",
    "write_step": "geometry.export",
    "write_stl": "geometry.export",
    "GeometryFigures": "geometry.figures",
    "compute_figures": "geometry.figures",
    "Impeller": "geometry.impeller",
    "FaceRoles": "geometry.interop",
    "impeller_part": "geometry.interop",
    "impeller_workplane": "geometry.interop",
    "occ_shape": "geometry.interop",
    "solid_mesh": "geometry.interop",
    "hub_contour": "geometry.meridional",
    "meridional_profile": "geometry.meridional",
    "with_hub": "geometry.meridional",
    "ImpellerSpec": "geometry.spec",
    "load_spec": "geometry.spec",
    "ImpellerSurfaces": "geometry.surfaces",
    "build_surfaces": "geometry.surfaces",
}

__all__ = [
    "ROLES",
    "DesignParameters",
    "FaceRoles",
    "GeometryFigures",
    "Impeller",
    "ImpellerSpec",
    "ImpellerSurfaces",
    "build_surfaces",
    "compute_figures",
    "generate",
    "hub_contour",
    "impeller_part",
    "impeller_workplane",
    "load_design",
    "load_spec",
    "meridional_profile",
    "occ_shape",
    "read_step",
    "solid_mesh",
    "spec_blank_profile",
    "with_hub",
    "write_design",
    "write_step",
    "write_stl",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
