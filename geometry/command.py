"""``impeller-cam geometry``: STEP, STL, geometry.json and a PNG render into OUT/."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from geometry.figures import check_clearances
from geometry.impeller import Impeller
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.errors import InputError

__all__ = ["run_geometry"]


def run_geometry(spec: Path, out: Path, *, tessellation: float = 0.02, render: bool = True,
                 fillets: bool = True) -> None:
    """Build the impeller of ``spec`` and write its outputs into ``out`` (all or nothing).

    Raises
    ------
    InputError
        Bad spec or option (nothing is written).
    """
    if not tessellation > 0:
        raise InputError("must be positive", field="--tessellation", value=tessellation,
                         accepted="a linear deflection > 0 mm")
    say = (lambda m: print(f"geometry: {m}", file=sys.stderr)) if sys.stderr.isatty() \
        else (lambda m: None)
    impeller = Impeller.from_spec(spec, fillets=fillets)
    check_clearances(impeller.surfaces)  # blades touching, fillet too large: exit 2, no output
    say("building the solid")
    start = time.perf_counter()
    solid = impeller.solid
    build = time.perf_counter() - start
    with staged_directory(out) as stage:
        say("writing STEP")
        impeller.export_step(stage / "impeller.step")
        say("writing STL")
        impeller.export_stl(stage / "impeller.stl", tolerance=tessellation)
        figures = dict(impeller.figures)
        figures["faces_per_role"] = impeller.role_counts()
        figures["tessellation_mm"] = tessellation
        figures["build_seconds"] = round(build, 3)
        write_text_atomic(stage / "geometry.json", json.dumps(figures, indent=2, sort_keys=True)
                          + "\n")
        if render:
            from geometry.render import render_png

            say("rendering")
            render_png(impeller.mesh(tolerance=tessellation),
                       impeller.triangle_roles(tessellation), stage / "impeller.png")
    del solid
