"""Geometry script: a sweep of design variants through the design generator.

Each variant of the small fixture's design (blade count x fillet radius) is generated
(``geometry.generate`` via ``write_design``: spec.toml + camber CSVs), built as a
solid, and its figures are tabulated: narrowest passage ``d_min``, the largest
roughing ball ``r_max``, volume, and whether every face role is present.

Run from anywhere::

    .venv/bin/python docs/examples/design_sweep.py --blades 5 6 7 --fillets 0.5 1.0

It writes one folder per variant and ``sweep.json`` into ``--out``
(default ``out/examples/design_sweep``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from geometry import Impeller, load_design, write_design

ROOT = Path(__file__).resolve().parents[2]
DESIGN = ROOT / "fixtures" / "impellers" / "small" / "design.toml"


def sweep(blades: list[int], fillets: list[float], out: Path) -> list[dict[str, object]]:
    """Build every (blade count, fillet radius) variant of the small design.

    Parameters
    ----------
    blades : list of int
        Main blade counts.
    fillets : list of float
        Blade-to-hub fillet radii, mm.
    out : Path
        Output folder (one sub-folder per variant).

    Returns
    -------
    list of dict
        Per variant: name, blades, fillet radius (mm), d_min (mm), r_max (mm), volume
        (mm^3), face count per role.
    """
    base = load_design(DESIGN)
    rows: list[dict[str, object]] = []
    for count in blades:
        for radius in fillets:
            name = f"small_b{count}_f{radius:g}"
            params = dataclasses.replace(base, name=name, blades=count, fillet_radius=radius)
            impeller = Impeller.from_spec(write_design(params, out / name))
            figures = impeller.figures
            rows.append({
                "name": name, "blades": count, "fillet_radius_mm": radius,
                "d_min_mm": round(figures["d_min_mm"], 4),
                "r_max_mm": round(figures["r_max_mm"], 4),
                "volume_mm3": round(figures["volume_mm3"], 2),
                "faces": impeller.role_counts(),
            })
            print(f"{name}: d_min {figures['d_min_mm']:.2f} mm, r_max {figures['r_max_mm']:.2f}"
                  f" mm, volume {figures['volume_mm3']:.0f} mm3")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blades", type=int, nargs="+", default=[5, 6, 7])
    parser.add_argument("--fillets", type=float, nargs="+", default=[0.5, 1.0],
                        help="fillet radii, mm")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "examples" / "design_sweep")
    args = parser.parse_args()
    rows = sweep(args.blades, args.fillets, args.out)
    (args.out / "sweep.json").write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
