"""``run.json``: the record of a chain run, and the per-stage time and memory meter.

Layout (docs/run.md)::

    {"format": "impeller-cam run 1", "spec": ..., "machine": ..., "impeller": name,
     "tools": {"rough": ..., "finish": ...}, "post": ..., "settings": {...},
     "versions": {...},
     "stages": [{"name", "status": "done" | "failed" | "not run", "seconds",
                 "peak_mb", "outputs": [relative paths], "error": str | null}, ...]}

``peak_mb`` is the peak resident memory of the process during the stage (native
memory included: Linux's ``VmHWM`` is reset before the stage through
``/proc/self/clear_refs``; where that is not possible, the process peak so far from
``getrusage``, which never decreases - ``peak_mb_kind`` says which).
"""

from __future__ import annotations

import json
import platform
import resource
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from impeller_cam.atomic import write_text_atomic

__all__ = ["STAGES", "MemoryMeter", "empty_record", "read_record", "stage_entry",
           "versions", "write_record"]

#: Stage names, in order.
STAGES = ("geometry", "rough", "finish", "post", "verify", "motion", "report")
RUN_JSON = "run.json"
FORMAT = "impeller-cam run 1"


def stage_entry(name: str, status: str = "not run") -> dict[str, Any]:
    """A fresh stage entry."""
    return {"name": name, "status": status, "seconds": None, "peak_mb": None,
            "outputs": [], "error": None}


def versions() -> dict[str, str]:
    """Versions of Python, impeller-cam and the main libraries."""
    from importlib import metadata

    out = {"python": platform.python_version()}
    for dist in ("impeller-cam", "numpy", "scipy", "trimesh", "build123d", "python-fcl",
                 "dask", "pyvista"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out


def empty_record(spec: Path, machine: Path, name: str, settings: dict[str, Any]
                 ) -> dict[str, Any]:
    """A run record with every stage "not run"."""
    return {
        "format": FORMAT,
        "spec": str(spec),
        "machine": str(machine),
        "impeller": name,
        "tools": {"rough": settings["rough_tool"], "finish": settings["finish_tool"]},
        "post": settings["post"],
        "settings": settings,
        "versions": versions(),
        "stages": [stage_entry(s) for s in STAGES],
    }


def read_record(out: Path) -> dict[str, Any] | None:
    """The run.json in ``out``, or None."""
    path = Path(out) / RUN_JSON
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
    return data if isinstance(data, dict) and data.get("format") == FORMAT else None


def write_record(out: Path, record: dict[str, Any]) -> Path:
    """Write run.json atomically."""
    return write_text_atomic(Path(out) / RUN_JSON,
                             json.dumps(record, indent=2, allow_nan=False) + "\n")


def _vm_hwm_kb() -> int | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def _reset_hwm() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def _maxrss_kb() -> int:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(rss / 1024) if sys.platform == "darwin" else int(rss)


def _cpu_seconds() -> float:
    """User + system seconds of this process and of the processes it forked and
    waited for (the finishing planner's, ``impeller_cam.processes``)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return float(usage.ru_utime + usage.ru_stime + children.ru_utime + children.ru_stime)


class MemoryMeter:
    """Wall time and peak resident memory of a block of work.

    Use ``with meter.measure(): ...``; then ``seconds`` (wall), ``cpu_seconds`` (user +
    system time of all the process's threads: on a shared machine the better measure
    of the work), ``peak_mb`` and ``kind``
    (``"stage"``: the peak of this block alone; ``"process"``: the process peak so far).
    """

    def __init__(self) -> None:
        self.seconds = 0.0
        self.cpu_seconds = 0.0
        self.peak_mb = 0.0
        self.kind = "stage"

    @contextmanager
    def measure(self) -> Iterator[MemoryMeter]:
        reset = _reset_hwm()
        start = time.perf_counter()
        cpu = _cpu_seconds()
        try:
            yield self
        finally:
            self.seconds = time.perf_counter() - start
            self.cpu_seconds = _cpu_seconds() - cpu
            hwm = _vm_hwm_kb() if reset else None
            if hwm is None:
                self.kind = "process"
                hwm = _maxrss_kb()
            self.peak_mb = hwm / 1024.0
