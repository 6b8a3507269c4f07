"""A sweep on a real Dask cluster: a scheduler and two workers as separate processes.

The workers run in working folders of their own (not the client's) and get nothing
but the tasks: the variants' designs, the machine file's text; the client writes
OUT/. Two variants of the small fixture (blade thickness 1.3 and 1.5 mm, each with a
fillet radius of 1.0 mm: two ``--vary`` columns) through geometry and roughing (one
passage roughed, coarse tessellation: the sweep's machinery is under test, not the
roughing) give the same sweep.csv as a local run, also when one worker is killed
mid-sweep (the scheduler reruns its task on the other). One variant per worker is
enough for both: each worker runs a task, and the killed one's is rerun on the other
(the cross product of several values per ``--vary`` is tests/cam/run/test_sweep.py's).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from cam.cli import main
from tests.cam.conftest import CHAIN_MACHINE, ROOT

pytestmark = pytest.mark.slow

DASK = Path(sys.executable).with_name("dask")
VARY = ["--vary", "blade.thickness_mm=1.3,1.5", "--vary", "blade.fillet_radius_mm=1.0"]
#: Coarse, quick settings of the sweep's base design (the small fixture's otherwise).
COARSE = {"verify_resolution_mm = 0.2\n": "verify_resolution_mm = 0.2\ntessellation_mm = 0.1\n",
          "[machining.rough]\nscallop_mm = 0.5\n":
          "[machining.rough]\nscallop_mm = 1.0\nstep_along_mm = 2.0\npassages = 1\n"}


def base_design(folder: Path) -> Path:
    """The small fixture's design.toml with coarse settings."""
    folder.mkdir(parents=True, exist_ok=True)
    text = (ROOT / "fixtures" / "impellers" / "small" / "design.toml").read_text()
    for old, new in COARSE.items():
        assert old in text
        text = text.replace(old, new)
    path = folder / "design.toml"
    path.write_text(text)
    return path


def sweep(design: Path, out: Path, *extra: str) -> int:
    return main(["sweep", str(design), "-m", str(CHAIN_MACHINE), "-o", str(out), *VARY,
                 "--stages", "rough", *extra])


class Cluster:
    """A scheduler and worker processes, each in its own folder and process group."""

    def __init__(self, root: Path, workers: int) -> None:
        self.root = root
        self.file = root / "scheduler.json"
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        self.processes: list[subprocess.Popen[bytes]] = []
        self.workers: list[subprocess.Popen[bytes]] = []
        self._start([str(DASK), "scheduler", "--scheduler-file", str(self.file), "--port",
                     "0", "--no-dashboard"], root / "scheduler", env)
        # the scheduler creates its file before it writes it: wait until it parses
        deadline = time.monotonic() + 120
        while True:
            try:
                self.address = json.loads(self.file.read_text())["address"]
                break
            except (FileNotFoundError, json.JSONDecodeError, KeyError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        for i in range(workers):
            self.workers.append(self._start(
                [str(DASK), "worker", "--scheduler-file", str(self.file), "--nthreads", "1",
                 "--no-nanny", "--no-dashboard", "--local-directory",
                 str(root / f"worker{i}" / "scratch")], root / f"worker{i}", env))
        from dask.distributed import Client

        with Client(self.address, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=120)

    def _start(self, args: list[str], cwd: Path, env: dict[str, str]
               ) -> subprocess.Popen[bytes]:
        cwd.mkdir(parents=True)
        log = open(cwd / "log.txt", "wb")  # noqa: SIM115 - closed with the process
        process = subprocess.Popen(args, cwd=cwd, env=env, stdout=log, stderr=log,
                                   start_new_session=True)
        self.processes.append(process)
        return process

    def kill(self, process: subprocess.Popen[bytes]) -> None:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)

    def close(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    self.kill(process)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    """One cluster for the module's two cluster tests (its start and the workers'
    imports are a good part of a test): the killed worker's test comes last."""
    running = Cluster(tmp_path_factory.mktemp("cluster"), workers=2)
    try:
        yield running
    finally:
        running.close()


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sweep on a local cluster (two processes): the reference."""
    root = tmp_path_factory.mktemp("local")
    out = root / "out"
    assert sweep(base_design(root / "design"), out, "--workers", "2") == 0
    return out


def figures(out: Path) -> list[dict[str, str]]:
    import csv

    with open(out / "sweep.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def assert_same_table(out: Path, reference: Path) -> None:
    rows, expected = figures(out), figures(reference)
    assert [r["variant"] for r in rows] == [r["variant"] for r in expected]
    for got, want in zip(rows, expected, strict=True):
        assert got.keys() == want.keys()
        for key, value in want.items():
            try:
                assert float(got[key]) == pytest.approx(float(value), rel=1e-9, abs=1e-9), key
            except ValueError:
                assert got[key] == value, key


def test_local_sweep_rows(local_sweep: Path) -> None:
    rows = figures(local_sweep)
    assert len(rows) == 2 and {r["status"] for r in rows} == {"done"}
    for r in rows:
        variant = json.loads((local_sweep / r["variant"] / "variant.json").read_text())
        assert float(r["volume_mm3"]) == variant["figures"]["geometry"]["volume_mm3"]
        assert float(r["rough_cycle_s"]) == variant["figures"]["rough"]["cycle_s"] > 0
        assert int(r["rough_collisions"]) == 0
        assert (local_sweep / r["variant"] / "run" / "rough" / "rough.json").is_file()
    # thicker blades: less passage, more material
    by = {(r["blade.thickness_mm"], r["blade.fillet_radius_mm"]): r for r in rows}
    assert float(by["1.3", "1.0"]["d_min_mm"]) > float(by["1.5", "1.0"]["d_min_mm"])
    assert float(by["1.3", "1.0"]["volume_mm3"]) < float(by["1.5", "1.0"]["volume_mm3"])


def test_cluster_sweep_equals_local(cluster: Cluster, local_sweep: Path, tmp_path: Path
                                    ) -> None:
    out = tmp_path / "out"
    design = base_design(tmp_path / "design")
    assert sweep(design, out, "--scheduler", cluster.address) == 0
    assert_same_table(out, local_sweep)
    summary = json.loads((out / "sweep.json").read_text())
    pids = {str(p.pid) for p in cluster.workers}
    workers = {v["worker"].rsplit(":", 1)[1] for v in summary["variants"]}
    assert workers <= pids and str(os.getpid()) not in workers
    for i in range(2):  # the workers wrote nothing into their working folders
        assert sorted(p.name for p in (cluster.root / f"worker{i}").iterdir()) == \
            ["log.txt", "scratch"]


def test_killed_worker_still_gives_every_row(cluster: Cluster, local_sweep: Path,
                                            tmp_path: Path) -> None:
    from dask.distributed import Client

    out = tmp_path / "out"
    design = base_design(tmp_path / "design")
    codes: list[int] = []
    thread = threading.Thread(target=lambda: codes.append(
        sweep(design, out, "--scheduler", cluster.address)))
    thread.start()
    killed = None
    with Client(cluster.address, timeout="60s") as client:
        pids = client.run(os.getpid)  # worker address -> process id
        deadline = time.monotonic() + 300
        while killed is None and time.monotonic() < deadline:
            busy = [w for w, keys in client.processing().items()
                    if any(str(k).startswith("sweep-") for k in keys)]
            if busy:
                time.sleep(5)  # mid-task
                killed = next(p for p in cluster.workers if p.pid == pids[busy[0]])
                cluster.kill(killed)
            time.sleep(0.5)
    thread.join(timeout=1800)
    assert killed is not None and codes == [0]
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["done"] == 2
    survivors = {str(p.pid) for p in cluster.workers if p is not killed}
    assert {v["worker"].rsplit(":", 1)[1] for v in summary["variants"]} <= \
        survivors | {str(killed.pid)}
    assert_same_table(out, local_sweep)
