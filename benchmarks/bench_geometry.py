"""Benchmark: build the impeller B-rep with rolling-ball fillets for every fixture.

For each fixture (``small``, ``nine_blade``, ``splitter``), in a fresh subprocess:
build time of ``Impeller.solid`` (faces built directly and sewn, fillets included),
peak resident memory of the process (``ru_maxrss``), the acceptance checks (STEP
re-import as one valid solid, STL watertight, STL volume vs. STEP volume, exact
point-to-B-rep distance of 300 mesh vertices rotated by one pitch) and the worst
fillet deviation (fillet-face points vs. the closed-form ball centre at r_f).

Peer, measured in the same run: a mesh boolean with manifold3d, the union of the
hub body mesh (profile revolved, 720 sections) and every blade as a closed mesh
(its outline loop sampled as the B-rep is, reaching 10 % of the span into the hub),
*without* fillets (mesh booleans cannot make rolling-ball blends). The ratio of the
two times is printed.

Usage: ``python benchmarks/bench_geometry.py [small nine_blade splitter]``
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FIXTURES = ROOT / "fixtures" / "impellers"
NAMES = ("small", "nine_blade", "splitter")


def _blade_mesh(blade: object, spec: object, levels: int = 24) -> object:
    """Closed triangle mesh of one blade from v = 0 to v = 1.1 (no fillet)."""
    import trimesh

    from geometry.outline import blade_loop

    outline = blade_loop(blade, spec.leading_edge,  # type: ignore[arg-type, attr-defined]
                            spec.trailing_edge)  # type: ignore[attr-defined]
    counts = [97 if s.kind == "side" else 9 for s in outline]
    starts = np.concatenate([[0], np.cumsum([c - 1 for c in counts])])
    m = int(starts[-1])
    v = np.linspace(0.0, 1.1, levels)
    rings = []
    for vv in v:
        ring = [s.point(np.linspace(0.0, 1.0, c)[:-1], np.full(c - 1, vv))
                for s, c in zip(outline, counts, strict=True)]
        rings.append(np.vstack(ring))
    vertices = np.vstack(rings)
    j = next(k for k, s in enumerate(outline) if s.kind == "side" and k > 0)
    pressure = [*range(0, counts[0] - 1), int(starts[1])]
    suction = [*range(int(starts[j]), int(starts[j]) + counts[j] - 1), int(starts[j + 1]) % m]
    suction = suction[::-1]
    cap = [[pressure[i], pressure[i + 1], suction[i + 1]] for i in range(len(pressure) - 1)]
    cap += [[pressure[i], suction[i + 1], suction[i]] for i in range(len(pressure) - 1)]
    for region in (list(range(int(starts[1]), int(starts[j]) + 1)),
                   [*range(int(starts[j + 1]), m), 0]):
        hub = region[len(region) // 2]
        cap += [[hub, a, b] for a, b in zip(region, region[1:] + region[:1], strict=True)
                if hub not in (a, b)]
    k = np.arange(m)
    walls = []
    for level in range(levels - 1):
        a, b = level * m + k, level * m + (k + 1) % m
        c, d = a + m, b + m
        walls += [np.column_stack([a, b, d]), np.column_stack([a, d, c])]
    for cap_t in (np.array(cap), np.array(cap)[:, ::-1]):
        faces = [*walls, cap_t, cap_t[:, ::-1] + (levels - 1) * m]
        mesh = trimesh.Trimesh(vertices, np.vstack(faces), process=True)
        if mesh.is_winding_consistent:
            break
    if not (mesh.is_watertight and mesh.is_winding_consistent):
        raise RuntimeError("blade mesh is not closed")
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _hub_mesh(surfaces: object, spec: object) -> object:
    import trimesh

    hub = surfaces.hub  # type: ignore[attr-defined]
    zr = hub.meridian(np.linspace(0.0, 1.0, 400))
    (z0, _), (_, r1) = zr[0], zr[-1]
    bore = spec.bore_radius  # type: ignore[attr-defined]
    profile = np.vstack([zr[:, ::-1], [[r1, 0.0], [bore, 0.0], [bore, z0]], zr[:1, ::-1]])
    return trimesh.creation.revolve(profile[::-1], sections=720)


def _peer(name: str) -> dict[str, float]:
    """manifold3d union of the hub body and blade meshes (no fillets)."""
    import manifold3d

    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    spec = load_spec(FIXTURES / name / "spec.toml")
    surfaces = build_surfaces(spec)
    meshes = [_hub_mesh(surfaces, spec), *(_blade_mesh(b, spec) for b in surfaces.all_blades())]
    start = time.perf_counter()
    parts = [manifold3d.Manifold(manifold3d.Mesh(
        vert_properties=np.asarray(m.vertices, np.float32),  # type: ignore[attr-defined]
        tri_verts=np.asarray(m.faces, np.uint32))) for m in meshes]  # type: ignore[attr-defined]
    union = manifold3d.Manifold.batch_boolean(parts, manifold3d.OpType.Add)
    volume = float(union.volume())
    seconds = time.perf_counter() - start
    return {"peer_seconds": seconds, "peer_volume_mm3": volume,
            "peer_status": float(union.status() == manifold3d.Error.NoError)}


def _one(name: str) -> dict[str, float | str | int]:
    """Build and check one fixture (run in a fresh process)."""
    import trimesh
    from scipy.spatial import cKDTree

    sys.path.insert(0, str(ROOT / "tests" / "geometry"))
    from test_solids import _exact_distance  # type: ignore[import-not-found]

    from geometry.brep import is_valid, solids_of, volume
    from geometry.export import read_step
    from geometry.fillet import _v_limit, rolling_ball
    from geometry.impeller import Impeller
    from geometry.mesh import triangulate_faces
    from geometry.outline import blade_loop
    from geometry.surfaces import rotation_z

    impeller = Impeller.from_spec(FIXTURES / name / "spec.toml")
    start = time.perf_counter()
    solid = impeller.solid
    build = time.perf_counter() - start
    out: dict[str, float | str | int] = {"fixture": name, "build_seconds": build,
                                        "faces": len(impeller.built.part.faces),
                                        "fillet_faces": impeller.role_counts()["fillet"]}
    with tempfile.TemporaryDirectory() as tmp:
        step = impeller.export_step(Path(tmp) / "i.step")
        stl = impeller.export_stl(Path(tmp) / "i.stl", tolerance=0.02)
        found = solids_of(read_step(step))
        out["step_one_valid_solid"] = int(len(found) == 1 and is_valid(found[0]))
        v_step = volume(found[0])
        mesh = trimesh.load_mesh(stl)
        out["stl_watertight"] = int(mesh.is_watertight)
        out["volume_mm3"] = v_step
        out["stl_volume_rel_diff"] = abs(float(mesh.volume) - v_step) / v_step
    faces = impeller.built.part.faces
    parts = triangulate_faces(solid, faces, 0.05, 0.5)
    vertices = np.vstack([v for v, _ in parts])
    owner = np.concatenate([np.full(len(v), i) for i, (v, _) in enumerate(parts)])
    picked = vertices[np.random.default_rng(3).choice(len(vertices), 300, replace=False)]
    dist = _exact_distance(picked @ rotation_z(impeller.spec.pitch).T, faces, owner,
                           cKDTree(vertices))
    out["rotation_max_mm"] = float(dist.max())
    spec, blade = impeller.spec, impeller.surfaces.blades[0]
    radius, p = spec.fillet_radius, np.linspace(0.0, 1.0, 41)
    centres = [rolling_ball(s, impeller.surfaces.hub, radius, p,
                            _v_limit(blade, s.u_of(p), 2 * radius + 3.0)).centre
               for s in blade_loop(blade, spec.leading_edge, spec.trailing_edge)]
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools

    worst = 0.0
    for face in impeller.faces("fillet"):
        _, _, v0, v1 = BRepTools.UVBounds_s(face)
        surface = BRep_Tool.Surface_s(face)
        pts = np.array([[surface.Value(u, v).Coord() for v in np.linspace(v0, v1, 9)]
                        for u in p])
        err = min(float(np.abs(np.linalg.norm(pts - c[:, None], axis=2) - radius).max())
                  for c in centres)
        worst = max(worst, err) if err < 0.1 else worst
    out["fillet_max_dev_mm"] = worst
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    out.update(_peer(name))
    return out


def main(names: list[str]) -> None:
    print(f"{'fixture':11s} {'build s':>8s} {'peak MB':>8s} {'faces':>6s} {'STEP ok':>7s} "
          f"{'watertight':>10s} {'dV STL':>9s} {'rot mm':>9s} {'fillet mm':>9s} "
          f"{'peer s':>7s} {'ratio':>6s} {'peer dV':>8s}")
    for name in names:
        run = subprocess.run([sys.executable, __file__, "--one", name], capture_output=True,
                             text=True, check=False)
        if run.returncode != 0:
            print(f"{name:11s} FAILED: {run.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(run.stdout.strip().splitlines()[-1])
        ratio = r["build_seconds"] / r["peer_seconds"] if r["peer_seconds"] > 0 else math.nan
        print(f"{name:11s} {r['build_seconds']:8.2f} {r['peak_rss_mb']:8.0f} {r['faces']:6d} "
              f"{r['step_one_valid_solid']:7d} {r['stl_watertight']:10d} "
              f"{r['stl_volume_rel_diff']:9.2e} {r['rotation_max_mm']:9.1e} "
              f"{r['fillet_max_dev_mm']:9.1e} {r['peer_seconds']:7.2f} {ratio:6.1f} "
              f"{(r['volume_mm3'] - r['peer_volume_mm3']) / r['volume_mm3']:8.1e}")
    print("ratio = B-rep build with fillets (sewn) / manifold3d mesh union without fillets;\n"
          "peer dV = (B-rep volume - mesh-union volume) / B-rep volume (the fillets' share,\n"
          "plus the mesh union's chordal error)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--one":
        print(json.dumps(_one(sys.argv[2])))
    else:
        main(sys.argv[1:] or list(NAMES))
