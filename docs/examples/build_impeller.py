"""Geometry script: design a variant, build it, export it, and read its figures.

Run from anywhere: ``.venv/bin/python docs/examples/build_impeller.py [OUT]``.
It writes into ``OUT`` (default ``out/example/``).
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

from geometry.design import load_design
from geometry.design_files import write_design
from geometry.impeller import Impeller

HERE = Path(__file__).resolve().parents[2]
OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "out" / "example"

# 1. Start from the small fixture's design parameters and make a variant:
#    7 blades and a 2 degree mid-span twist (a non-ruled blade).
params = load_design(HERE / "fixtures" / "impellers" / "small" / "design.toml")
variant = dataclasses.replace(params, blades=7, midspan_wrap_offset=math.radians(2.0))
spec_path = write_design(variant, OUT / "design")  # spec.toml + camber CSVs, as a user writes

# 2. Build the impeller: closed-form surfaces, then the B-rep solid with fillets.
impeller = Impeller.from_spec(spec_path)
figures = impeller.figures
print(f"blades {figures['blades']}, volume {figures['volume_mm3']:.0f} mm3")
d_min, r_max = figures["d_min_mm"], figures["r_max_mm"]
print(f"d_min {d_min:.2f} mm -> largest roughing ball r_max {r_max:.2f} mm")
print(f"rule deviation {figures['rule_deviation_mm']:.3f} mm (flank-millability)")

# 3. Export and use the meshes (per face role) for CAM.
impeller.export_step(OUT / "variant.step")
impeller.export_stl(OUT / "variant.stl", tolerance=0.02)
hub = impeller.mesh(role="hub")
print(f"hub mesh: {len(hub.faces)} triangles, area {hub.area:.0f} mm2")

# 4. Closed-form surfaces, e.g. the suction side of blade 0 offset by a 3 mm ball radius.
blade = impeller.surfaces.blades[0]
centres = blade.offset(0.5, 0.9, side=-1, distance=3.0)
print("ball centre near the hub at mid-chord:", centres.round(3))
