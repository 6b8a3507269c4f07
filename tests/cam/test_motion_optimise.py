"""Positioning-time search (seed 000, M5): the 40 % claim, asymmetric <= symmetric,
Dask equals one process, Figs. 9 and 10."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cam.motion.optimise import Grid, optimise, paper_grid, value_range
from cam.motion.plant import TwoMassPlant, load_plant
from impeller_cam.errors import InputError

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "motion"

# The optimum of the paper's full grid with the fixture plant, measured by
# benchmarks/bench_motion.py (4,819,427 profiles):
#   best asymmetric  Amaxu 30000, Amaxd 16000 mm/s^2, Vmax 445 mm/s, S 0   -> 0.06902 s
#   best symmetric   A 20000 mm/s^2, Vmax 415 mm/s, S 115                  -> 0.09726 s
#   Case I           all maxima, S = 22                                    -> 0.17992 s
# The coarse grid below contains both optima (S 0 and 115, A 16000/20000/30000,
# V 415/445/500), so its answers are the full grid's.
COARSE = Grid(
    value_range(0.0, 115.0, 5.0, "s"),
    value_range(10000.0, 30000.0, 2000.0, "a"),
    value_range(10000.0, 30000.0, 2000.0, "a"),
    np.concatenate([value_range(205.0, 490.0, 15.0, "v"), [500.0]]),
)


@pytest.fixture(scope="module")
def plant() -> TwoMassPlant:
    return load_plant(FIXTURES / "indexing_table.toml")[0]


@pytest.fixture(scope="module")
def coarse(plant: TwoMassPlant):  # type: ignore[no-untyped-def]
    return optimise(plant, 20.0, COARSE, workers=0, tasks=8)


def test_paper_grid_size() -> None:
    grid = paper_grid()
    assert grid.shape == (47, 41, 41, 61)
    assert grid.size == 4_819_427


def test_optimum_beats_case_one_by_forty_percent(coarse) -> None:  # type: ignore[no-untyped-def]
    times = coarse.as_dict()["positioning_time_s"]
    assert coarse.case_max.s_factor == 22.0
    assert coarse.case_max.amax_up == 30000.0 and coarse.case_max.vmax == 500.0
    assert times["best"] <= 0.6 * times["case_max"]
    assert times["best"] <= times["best_symmetric"]  # asymmetric no worse, as the paper
    assert coarse.best_symmetric.amax_up == coarse.best_symmetric.amax_down
    # the coarse grid holds the full grid's optima (see the note above)
    assert (coarse.best.amax_up, coarse.best.amax_down, coarse.best.vmax,
            coarse.best.s_factor) == (30000.0, 16000.0, 445.0, 0.0)
    assert (coarse.best_symmetric.amax_up, coarse.best_symmetric.vmax,
            coarse.best_symmetric.s_factor) == (20000.0, 415.0, 115.0)


def test_result_is_the_minimum_of_its_table(coarse) -> None:  # type: ignore[no-untyped-def]
    assert coarse.best.positioning_time == pytest.approx(float(coarse.times.min()), abs=1e-12)
    sym = [coarse.times[:, i, i, :].min() for i in range(len(COARSE.amax_up))]
    assert coarse.best_symmetric.positioning_time == pytest.approx(min(sym), abs=1e-12)


def test_dask_local_cluster_equals_one_process(plant: TwoMassPlant) -> None:
    small = Grid(np.array([0.0, 50.0, 105.0]), np.array([14000.0, 30000.0]),
                 np.array([14000.0, 30000.0]), np.array([300.0, 500.0]))
    serial = optimise(plant, 20.0, small, workers=0, tasks=4)
    parallel = optimise(plant, 20.0, small, workers=2, tasks=4)
    assert np.array_equal(serial.times, parallel.times)


def test_unreachable_scheduler_is_an_input_error(plant: TwoMassPlant) -> None:
    small = Grid(np.array([0.0]), np.array([1e4]), np.array([1e4]), np.array([200.0]))
    with pytest.raises(InputError, match="scheduler"):
        optimise(plant, 20.0, small, scheduler="tcp://127.0.0.1:9", tasks=1,
                 connect_timeout=1.0)


def test_figures(coarse, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from cam.motion.plots import plot_time_over_av, plot_time_vs_s

    for path in (plot_time_vs_s(coarse, tmp_path / "fig9.png"),
                 plot_time_over_av(coarse, tmp_path / "fig10.png")):
        data = path.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


@pytest.mark.parametrize("args", [(0.0, 10.0, 0.0), (5.0, 1.0, 1.0), (0.0, float("nan"), 1.0)])
def test_bad_ranges(args: tuple[float, float, float]) -> None:
    with pytest.raises(InputError):
        value_range(*args, "s")


def test_bad_stroke(plant: TwoMassPlant) -> None:
    with pytest.raises(InputError):
        optimise(plant, -1.0, COARSE, workers=0)
