"""Benchmark: post one million GOTO records (synthetic 5-axis path, AC table).

Posts a synthetic simultaneous five-axis path of ``--records`` CL poses for the
representative trunnion machine (xyzac-trt, continuous C) with the ``linuxcnc``
dialect: inverse kinematics, rotary linearisation (chordal 0.01 mm, angular 0.5 deg),
feeds (G93), travel check, vectorised formatting and an atomic write. It prints
records/s and the peak memory (tracemalloc, second run) of the vectorised post.

Peer, measured in the same run: the naive approach, a plain per-record Python loop
(scalar inverse kinematics with branch and C unwinding, travel check, the same
7-sample chordal/angular test per segment with recursive halving, inverse-time feed,
f-string formatting) on the first ``--peer-records`` records. The ratio of the two
records/s is printed.

Usage: ``python benchmarks/bench_post.py [--records 1000000] [--peer-records 20000]``
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impeller_cam.atomic import write_text_atomic  # noqa: E402
from postproc.kinematics import kinematics_for  # noqa: E402
from postproc.machine import Machine, load_machine  # noqa: E402
from postproc.posting import post_toolpaths  # noqa: E402
from postproc.posts import PostOptions, get_post  # noqa: E402
from postproc.toolpath import MoveKind, Toolpath  # noqa: E402

MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


def synthetic_path(n: int) -> Toolpath:
    """A dense simultaneous 5-axis spiral: C winds ~100 turns, the tilt oscillates."""
    s = np.linspace(0.0, 1.0, n)
    phi = 2.0 * np.pi * 100.0 * s
    tilt = np.radians(22.0 + 15.0 * np.sin(2.0 * np.pi * 37.0 * s))
    axis = np.stack([np.sin(tilt) * np.sin(phi), np.sin(tilt) * np.cos(phi), np.cos(tilt)], 1)
    radius = 40.0 + 15.0 * np.sin(2.0 * np.pi * 11.0 * s)
    tip = np.stack([radius * np.cos(phi), radius * np.sin(phi),
                    30.0 + 10.0 * np.sin(2.0 * np.pi * 5.0 * s)], 1)
    kind = np.full(n, MoveKind.FEED, dtype=np.int8)
    kind[0] = MoveKind.RAPID
    feed = np.full(n, 1500.0)
    feed[0] = np.nan
    return Toolpath(tip=tip, axis=axis, feed=feed, kind=kind, name="benchmark spiral",
                    tool_number=1, spindle_rpm=12000.0,
                    source_records=np.arange(1, n + 1, dtype=np.int32))


def post_vectorised(path: Toolpath, machine: Machine, out: Path) -> int:
    """The library's post: returns the number of blocks written."""
    options = PostOptions()
    posted = post_toolpaths([path], machine, options)
    write_text_atomic(out, get_post("linuxcnc").write(posted, options))
    return len(posted)


# --------------------------------------------------------------------- naive peer
def post_naive(path: Toolpath, machine: Machine, out: Path) -> int:
    """A plain per-record Python loop doing the same job (the naive approach)."""
    kins = kinematics_for(machine)
    rot = [float(v) for v in kins.rot_point]  # type: ignore[attr-defined]
    off = [float(v) for v in kins.offset]  # type: ignore[attr-defined]
    sign = float(kins.sign)  # type: ignore[attr-defined]
    lower, upper = machine.limits()
    chordal, angular = 0.01, math.radians(0.5)

    def rot_x(v, a):
        c, s = math.cos(a), math.sin(a)
        return (v[0], c * v[1] - s * v[2], s * v[1] + c * v[2])

    def rot_z(v, a):
        c, s = math.cos(a), math.sin(a)
        return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])

    def forward(q):
        rel = (q[0] - rot[0] - off[0], q[1] - rot[1] - off[1], q[2] - rot[2] - off[2])
        w = rot_x(rel, -sign * q[3])
        tip = rot_z((w[0] + off[0], w[1] + off[1], w[2] + off[2]), -sign * q[4])
        axis = rot_z(rot_x((0.0, 0.0, 1.0), -sign * q[3]), -sign * q[4])
        return tip, axis

    def inverse(tip, axis, prev):
        theta = math.atan2(math.hypot(axis[0], axis[1]), axis[2])
        phi = math.atan2(axis[0], axis[1])
        best = None
        for t, c in ((theta, phi), (-theta, phi + math.pi)):
            a, c = sign * t, sign * c
            c += 2.0 * math.pi * round((prev[4] - c) / (2.0 * math.pi))
            cost = abs(a - prev[3]) + abs(c - prev[4])
            if best is None or cost < best[0]:
                best = (cost, a, c)
        assert best is not None
        _, a, c = best
        v = rot_z(tip, sign * c)
        v = rot_x((v[0] - off[0], v[1] - off[1], v[2] - off[2]), sign * a)
        q = [v[0] + rot[0] + off[0], v[1] + rot[1] + off[1], v[2] + rot[2] + off[2], a, c]
        for j in range(5):
            if not lower[j] <= q[j] <= upper[j]:
                raise ValueError(f"over-travel axis {j}")
        return q

    def dist_segment(p, s0, s1):
        d = [s1[k] - s0[k] for k in range(3)]
        dd = sum(x * x for x in d)
        t = 0.0 if dd == 0 else max(0.0, min(1.0, sum((p[k] - s0[k]) * d[k]
                                                      for k in range(3)) / dd))
        return math.dist(p, [s0[k] + t * d[k] for k in range(3)])

    def angle(u, v):
        return math.acos(max(-1.0, min(1.0, sum(u[k] * v[k] for k in range(3)))))

    def pieces(q0, q1, p0, p1, a0, a1, u0, u1, depth, out_rows):
        ok = True
        for i in range(1, 8):
            t = i / 8.0
            q = [q0[k] + t * (q1[k] - q0[k]) for k in range(5)]
            tip, ax = forward(q)
            if dist_segment(tip, p0, p1) > chordal or min(angle(ax, a0), angle(ax, a1)) > \
                    angular + angle(a0, a1):
                ok = False
                break
        if ok or depth > 20:
            out_rows.append(q1)
            return
        um = 0.5 * (u0 + u1)
        tip = [p0[k] + um * (p1[k] - p0[k]) for k in range(3)]
        ax = [a0[k] + um * (a1[k] - a0[k]) for k in range(3)]
        norm = math.sqrt(sum(x * x for x in ax))
        qm = inverse(tip, [x / norm for x in ax], [0.5 * (q0[k] + q1[k]) for k in range(5)])
        pieces(q0, qm, p0, p1, a0, a1, u0, um, depth + 1, out_rows)
        pieces(qm, q1, p0, p1, a0, a1, um, u1, depth + 1, out_rows)

    lines = ["G21 G17 G40 G80 G90 G94 G54", "T1 M6", "G43 H1", "S12000 M3"]
    tips, axes, feeds = path.tip.tolist(), path.axis.tolist(), path.feed.tolist()
    prev = [0.0] * 5
    q_prev = None
    for i in range(len(tips)):
        q = inverse(tips[i], axes[i], prev)
        if q_prev is None:
            lines.append(f"G0 X{q[0]:.4f} Y{q[1]:.4f} Z{q[2]:.4f} "
                         f"A{math.degrees(q[3]):.4f} C{math.degrees(q[4]):.4f}")
        else:
            rows: list[list[float]] = []
            pieces(q_prev, q, tips[i - 1], tips[i], axes[i - 1], axes[i], 0.0, 1.0, 0, rows)
            start = q_prev
            for row in rows:
                tip0, _ = forward(start)
                tip1, _ = forward(row)
                minutes = max(math.dist(tip0, tip1) / feeds[i], 1e-9)
                lines.append(f"G93 G1 X{row[0]:.4f} Y{row[1]:.4f} Z{row[2]:.4f} "
                             f"A{math.degrees(row[3]):.4f} C{math.degrees(row[4]):.4f} "
                             f"F{1.0 / minutes:.3f}")
                start = row
        prev = q_prev = q
    lines.append("M2")
    write_text_atomic(out, "\n".join(lines) + "\n")
    return len(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=1_000_000)
    parser.add_argument("--peer-records", type=int, default=20_000)
    args = parser.parse_args()
    machine = load_machine(MACHINE)
    path = synthetic_path(args.records)
    peer_path = synthetic_path(args.records)
    peer_path = Toolpath(tip=peer_path.tip[: args.peer_records],
                         axis=peer_path.axis[: args.peer_records],
                         feed=peer_path.feed[: args.peer_records],
                         kind=peer_path.kind[: args.peer_records])
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.ngc"
        post_vectorised(synthetic_path(2000), machine, out)  # warm up (numba caches)
        start = time.perf_counter()
        blocks = post_vectorised(path, machine, out)
        seconds = time.perf_counter() - start
        size = out.stat().st_size
        tracemalloc.start()
        post_vectorised(path, machine, out)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        start = time.perf_counter()
        peer_blocks = post_naive(peer_path, machine, Path(tmp) / "naive.ngc")
        peer_seconds = time.perf_counter() - start
    rate = args.records / seconds
    peer_rate = args.peer_records / peer_seconds
    print(f"vectorised post : {args.records} GOTO records -> {blocks} blocks, "
          f"{size / 1e6:.1f} MB in {seconds:.2f} s = {rate:,.0f} records/s")
    print(f"peak memory     : {peak / 1e6:.0f} MB (tracemalloc, whole post incl. text)")
    print(f"naive loop peer : {args.peer_records} records -> {peer_blocks} lines in "
          f"{peer_seconds:.2f} s = {peer_rate:,.0f} records/s")
    print(f"speed ratio     : {rate / peer_rate:.1f}x (vectorised / naive per-record loop)")


if __name__ == "__main__":
    main()
