"""Benchmark: the paper's full positioning-time grid (seed 000) three ways, one run.

1. impeller-cam, one process (closed-form residual + numba): the whole grid.
2. impeller-cam on Dask, a LocalCluster with two worker processes: the same grid
   (cluster start-up and the workers' first import timed separately).
3. ``scipy.signal.lsim`` per profile (the plant simulated from rest over the access time
   plus a settling window at the 250 us PID period, settling read from the samples),
   timed on a random sample of the grid and scaled to the grid size.

Prints the times, the ratios (target: lsim / impeller-cam >= 1000) and the largest
disagreement of the positioning times on the sample (should be ~ one PID period).

Run:  .venv/bin/python benchmarks/bench_motion.py [--sample 40] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from cam.motion.optimise import optimise, paper_grid
from cam.motion.plant import load_plant
from cam.motion.positioning import Settling, settling_time_sampled
from cam.motion.scurve import plan_scurve, sample_scurve

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "motion" / "indexing_table.toml"
STROKE = 20.0
WINDOW = 0.4  # s of settling window simulated after the move by lsim


def lsim_positioning(plant, params, settling: Settling) -> tuple[float, float]:
    """Positioning time of one profile with scipy.signal.lsim; returns (time, seconds)."""
    from scipy.signal import lsim

    a, b, c, d = plant.state_space(settling.output)
    start = time.perf_counter()
    profile = plan_scurve(STROKE, *params)
    access = float(profile.duration[0])
    t = np.arange(int(np.ceil((access + WINDOW) / settling.dt)) + 1) * settling.dt
    _, acc, vel, pos = sample_scurve(profile, t)
    u = np.stack([pos[0], vel[0], acc[0]], axis=1)
    _, y, _ = lsim((a, b, c, d), u, t, interp=False)
    end = int(np.ceil(access / settling.dt))
    target = 0.0 if settling.output == "acceleration" else STROKE
    settle = settling_time_sampled(y[None, :], end, target, settling.band, settling.dt)[0]
    settle += end * settling.dt - access  # from the end of the move, as the closed form
    return access + settle, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=40, help="lsim profiles to time")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    load_before = os.getloadavg()
    plant, _ = load_plant(FIXTURE)
    settling = Settling()
    grid = paper_grid()
    # warm-up: numba compilation is not part of the measurement
    optimise(plant, STROKE, grid=type(grid)(grid.s_factor[:2], grid.amax_up[:2],
                                            grid.amax_down[:2], grid.vmax[:2]), workers=0)

    start = time.perf_counter()
    serial = optimise(plant, STROKE, grid, settling, workers=0)
    t_serial = time.perf_counter() - start

    from dask.distributed import Client, LocalCluster

    start = time.perf_counter()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    tiny = type(grid)(grid.s_factor[:2], grid.amax_up[:2], grid.amax_down[:2], grid.vmax[:2])
    optimise(plant, STROKE, tiny, settling, client=client, tasks=4)  # imports, numba cache
    t_startup = time.perf_counter() - start
    start = time.perf_counter()
    parallel = optimise(plant, STROKE, grid, settling, client=client)
    t_dask = time.perf_counter() - start
    client.close()
    cluster.close()
    same = bool(np.array_equal(serial.times, parallel.times))

    rng = np.random.default_rng(2024)
    flat = rng.choice(grid.size, size=args.sample, replace=False)
    lsim_times, lsim_seconds, ours = [], [], []
    for index in flat:
        v, au, ad, s = (float(x[0]) for x in grid.parameters(int(index), int(index) + 1))
        value, seconds = lsim_positioning(plant, (v, au, ad, s), settling)
        lsim_times.append(value)
        lsim_seconds.append(seconds)
        ours.append(float(serial.times.flat[index]))
    per_profile = float(np.mean(lsim_seconds))
    projected = per_profile * grid.size
    finite = np.isfinite(lsim_times)
    disagreement = float(np.max(np.abs(np.array(lsim_times)[finite]
                                       - np.array(ours)[finite])))
    result = {
        "profiles": grid.size,
        "impeller_cam_one_process_s": t_serial,
        "impeller_cam_dask_2_workers_s": t_dask,
        "dask_cluster_startup_s": t_startup,
        "dask_speedup": t_serial / t_dask,
        "dask_equals_one_process": same,
        "lsim_per_profile_s": per_profile,
        "lsim_projected_full_grid_s": projected,
        "speedup_vs_lsim_one_process": projected / t_serial,
        "speedup_vs_lsim_dask": projected / t_dask,
        "lsim_sample": int(args.sample),
        "lsim_sample_unsettled": int((~finite).sum()),
        "max_positioning_time_difference_s": disagreement,
        "load_average_before_after": [load_before[0], os.getloadavg()[0]],
        "cpus": os.cpu_count(),
        "best": serial.best.as_dict(),
        "best_symmetric": serial.best_symmetric.as_dict(),
        "case_max": serial.case_max.as_dict(),
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"full paper grid: {grid.size} profiles, stroke {STROKE} mm")
    print(f"impeller-cam, one process   {t_serial:9.2f} s")
    print(f"impeller-cam, Dask 2 workers {t_dask:8.2f} s   ({t_serial / t_dask:.2f}x, "
          f"identical: {same}; cluster start-up {t_startup:.1f} s not included)")
    print(f"scipy.signal.lsim           {projected:9.0f} s projected "
          f"({per_profile * 1e3:.2f} ms/profile on {args.sample} profiles)")
    print(f"speed-up vs lsim            {projected / t_serial:9.0f}x one process, "
          f"{projected / t_dask:.0f}x Dask (target >= 1000x)")
    print(f"largest positioning-time difference on the sample: {disagreement * 1e3:.3f} ms")
    print(f"load average (1 min) before/after: {load_before[0]:.1f} / "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs (shared machine)")
    print(f"best {serial.best.positioning_time:.4f} s {serial.best.as_dict()}")
    print(f"best symmetric {serial.best_symmetric.positioning_time:.4f} s "
          f"{serial.best_symmetric.as_dict()}")
    print(f"case I (all maxima, S = 22) {serial.case_max.positioning_time:.4f} s")


if __name__ == "__main__":
    main()
