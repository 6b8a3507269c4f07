"""build123d script: the impeller as a build123d Part, a keyway and a balancing groove
added, face roles kept, STEP written.

The keyway (``--key-width`` wide, reaching ``--key-reach`` from the axis) runs the
whole bore; the balancing groove is an annulus cut into the back face. The faces
keep their roles through the edit (``geometry.FaceRoles``): the blades, fillets and
hub untouched, the bore cut open, the back face split by the groove, and the new
faces (keyway and groove walls) without a role.

Run from anywhere::

    .venv/bin/python docs/examples/build123d_keyway.py --out out/examples/keyway

It writes ``impeller_keyway.step`` and prints the removed volume and the faces per role.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import build123d as bd

from geometry import FaceRoles, Impeller, impeller_part

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"


def keyway_and_groove(part: bd.Part, key_width: float, key_reach: float,
                      groove: tuple[float, float, float]) -> bd.Part:
    """Cut a keyway along the bore and a balancing groove into the back face (z = 0).

    Parameters
    ----------
    part : build123d.Part
        The impeller, its axis Z, back face at z = 0, mm.
    key_width : float
        Width of the keyway, mm (centred on the XZ plane).
    key_reach : float
        Distance from the axis to the keyway's flat bottom, mm (beyond the bore).
    groove : (float, float, float)
        Inner radius, outer radius and depth of the groove, mm.

    Returns
    -------
    build123d.Part
        The edited impeller.
    """
    inner, outer, depth = groove
    key = bd.Box(key_width, key_reach, 1000.0,
                 align=(bd.Align.CENTER, bd.Align.MIN, bd.Align.CENTER))
    ring = (bd.Cylinder(outer, depth, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
            - bd.Cylinder(inner, depth, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN)))
    return part - key - ring


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", type=Path, default=SPEC)
    parser.add_argument("--key-width", type=float, default=2.0, help="mm")
    parser.add_argument("--key-reach", type=float, default=5.5, help="mm")
    parser.add_argument("--groove", type=float, nargs=3, default=[30.0, 38.0, 1.0],
                        metavar=("INNER", "OUTER", "DEPTH"), help="mm")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "examples" / "keyway")
    args = parser.parse_args()

    impeller = Impeller.from_spec(args.spec)
    part = impeller_part(impeller)
    edited = keyway_and_groove(part, args.key_width, args.key_reach, tuple(args.groove))
    roles = FaceRoles.of(impeller)
    print(f"removed {part.volume - edited.volume:.3f} mm3")
    for role, count in roles.counts(edited).items():
        print(f"  {role or 'new (no role)'}: {count} faces")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "impeller_keyway.step"
    if not bd.export_step(edited, str(path)):
        raise SystemExit(f"STEP export failed: {path}")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
