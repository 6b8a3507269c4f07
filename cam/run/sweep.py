"""``run_sweep``: design variants through the chain on Dask, and the table that compares them.

``impeller-cam sweep DESIGN.toml --vary PATH=VALUES ... -m MACHINE -o OUT/`` (docs/sweep.md):

1. the variants (``cam.run.sweep_params``): cross product of the ``--vary`` values or a
   seeded Latin hypercube (``samples``), each named ``<design>_<index>``;
2. one Dask task per variant (``cam.run.sweep_task.variant_task``) carrying its inputs
   (design dict, machine file text, tool library text) and returning its figures and
   files: nothing relies on a filesystem shared with the workers. ``retries`` reruns a
   task that raised; a task whose worker died is rerun by the scheduler on another
   worker (``distributed.scheduler.allowed-failures`` times); a variant that is
   invalid or fails is a row, never the end of the sweep;
3. as each variant returns, the client writes ``OUT/<variant>/`` whole (staged in a
   hidden sibling and renamed into place: no partial variant folder): its files and
   ``variant.json`` (status, parameters, figures, the task's wall time and worker);
4. at the end ``OUT/sweep.csv``, ``OUT/sweep.parquet`` (with pyarrow),
   ``OUT/sweep.json`` (counts, timings, the variants' status) and ``OUT/sweep.html``.

Progress: a line (``impeller_cam.progress.count_line``: done / running / failed /
invalid / queued) whenever a variant ends and at least every ``heartbeat_s`` seconds.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any

from cam.run.sweep_params import Variant, parse_vary, variants
from cam.run.sweep_table import columns, row, write_csv, write_parquet
from cam.run.sweep_task import FILE_MODES, chain_stages, variant_task
from impeller_cam.atomic import replace_path, write_bytes_atomic, write_text_atomic
from impeller_cam.cluster import dask_client
from impeller_cam.errors import InputError
from impeller_cam.progress import count_line

__all__ = ["VARIANT_JSON", "run_sweep", "write_variant"]

VARIANT_JSON = "variant.json"
FORMAT = "impeller-cam sweep 1"


def _safe(rel: str) -> bool:
    parts = Path(rel).parts
    return bool(parts) and not Path(rel).is_absolute() and ".." not in parts


def write_variant(out: Path, result: dict[str, Any], design: dict[str, Any]) -> dict[str, Any]:
    """Write ``OUT/<variant>/`` whole from a task's result; return its variant.json.

    The folder is built in a hidden sibling and renamed into place (an older folder of
    that name is replaced as a whole), so it is either complete or absent.
    """
    import tomli_w

    name = result["name"]
    files: dict[str, bytes] = dict(result.get("files") or {})
    files.setdefault("design.toml", tomli_w.dumps(design).encode("utf-8"))
    record = {key: value for key, value in result.items() if key != "files"}
    record = {"format": f"{FORMAT} variant", **record, "files": sorted(files)}
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{name}-staging-", dir=out))
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(stage, 0o777 & ~mask)  # mkdtemp's 0o700 would be the published folder's
    try:
        for rel, data in files.items():
            if not _safe(rel):
                raise ValueError(f"variant {name}: unsafe file path {rel!r}")
            write_bytes_atomic(stage / rel, data)
        write_text_atomic(stage / VARIANT_JSON,
                          json.dumps(record, indent=2, sort_keys=True) + "\n")
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    replace_path(stage, out / name)
    return record


def _lost(job: dict[str, Any], error: BaseException) -> dict[str, Any]:
    """The result of a task that never returned (its workers died, the retries ran out)."""
    return {"name": job["name"], "parameters": job["parameters"], "stages": job["stages"],
            "status": "failed", "stage": None, "kind": "internal", "figures": None,
            "error": f"{type(error).__name__}: {error}", "worker": None, "seconds": None}


def _jobs(design: Path, vary: list[str], samples: int | None, seed: int, stages: str,
          machine: Path, library: Path | None, files: str, settings: dict[str, Any]
          ) -> tuple[list[Variant], list[dict[str, Any]], list[str]]:
    from geometry.design import load_design
    from impeller_cam.schema import load_toml

    if not vary:
        raise InputError("nothing to vary", field="--vary",
                         accepted="one or more PATH=VALUES (docs/sweep.md)")
    if files not in FILE_MODES:
        raise InputError("unknown choice", field="--files", value=files,
                         accepted=", ".join(FILE_MODES))
    chain_stages(stages)
    base = load_design(design)  # the base design must be valid: bad input otherwise
    data = load_toml(design, "design")
    data.setdefault("impeller", {})
    parameters = [parse_vary(v, data) for v in vary]
    found = variants(data, parameters, base.name, samples, seed)
    for path, what in ((machine, "machine TOML"), (library, "tool library TOML")):
        if path is not None and not Path(path).is_file():
            raise InputError(f"{what} not found", file=path, value=str(path),
                             accepted=f"an existing {what}")
    shipped_machine = {"name": Path(machine).name, "text": Path(machine).read_text("utf-8")}
    shipped_library = None if library is None else {
        "name": Path(library).name, "text": Path(library).read_text("utf-8")}
    for key in ("tool", "rough_tool", "finish_tool", "fillet_tool"):
        if settings.get(key) and ":" in str(settings[key]):
            raise InputError("give the tool's name and the library with --library",
                             field=f"--{key.replace('_', '-')}", value=settings[key],
                             accepted="a tool name (of --library, default the bundled one)")
    jobs = [{"name": v.name, "parameters": v.parameters, "design": v.design,
             "machine": shipped_machine, "library": shipped_library, "stages": stages,
             "settings": settings, "files": files} for v in found]
    return found, jobs, [p.path for p in parameters]


def _running(client: Any, keys: set[str]) -> int:
    """Variants being worked on: tasks of ``keys`` the workers hold, at most one per
    worker thread (a worker may hold a task queued behind the running one)."""
    try:
        processing = client.processing()
        threads = client.nthreads()
    except Exception:  # noqa: BLE001 - progress only
        return 0
    return sum(min(len(keys & set(map(str, tasks))), int(threads.get(worker, 1)))
               for worker, tasks in processing.items())


def run_sweep(
    design: str | Path,
    vary: list[str],
    machine: str | Path,
    out: str | Path,
    *,
    samples: int | None = None,
    seed: int = 0,
    stages: str = "rough",
    scheduler: str | None = None,
    workers: int = 2,
    library: str | Path | None = None,
    files: str = "json",
    retries: int = 2,
    connect_timeout: float = 10.0,
    heartbeat_s: float = 60.0,
    **settings: Any,
) -> dict[str, Any]:
    """Run a design sweep; write OUT/<variant>/, sweep.csv/.parquet/.json/.html.

    Parameters
    ----------
    design : str or Path
        The base design TOML (``impeller-cam design``'s input; it must be valid).
    vary : list of str
        ``PATH=VALUES`` arguments (``cam.run.sweep_params``).
    machine : str or Path
        Machine TOML (its text is sent to the workers).
    out : str or Path
        Output folder.
    samples : int, optional
        Latin hypercube of this many variants (default: the cross product).
    seed : int
        Seed of the Latin hypercube.
    stages : str
        Last stage run: ``design``, ``geometry``, ``rough``, ``finish`` or ``all``.
    scheduler : str, optional
        Address of a running Dask scheduler; default a local cluster of ``workers``.
    workers : int
        Local worker processes (>= 1).
    library : str or Path, optional
        Tool library TOML (sent to the workers; tool names refer to it); default the
        bundled library.
    files : str
        Files returned per variant: ``"json"`` (design, spec, JSON files) or ``"all"``.
    retries : int
        Dask retries of a task that raised.
    connect_timeout : float
        Seconds to wait for ``scheduler``.
    heartbeat_s : float
        Longest time between two progress lines, s.
    **settings
        ``run_chain`` keywords for every variant (``tool``, ``rough_tool``,
        ``finish_tool``, ``fillet_tool``, ``post``, ``verify_resolution_mm``).

    Returns
    -------
    dict
        sweep.json content: ``done``, ``failed``, ``invalid`` counts, ``variants``.

    Raises
    ------
    InputError
        Bad base design, ``--vary``, choice, machine, library or scheduler (nothing
        written).
    """
    from dask.distributed import wait

    if workers < 1:
        raise InputError("must be >= 1", field="--workers", value=workers,
                         accepted="a number of local worker processes")
    design, machine, out = Path(design), Path(machine), Path(out)
    found, jobs, parameters = _jobs(design, vary, samples, seed, stages, machine,
                                    None if library is None else Path(library), files,
                                    settings)
    by_name = {v.name: v for v in found}
    records: dict[str, dict[str, Any]] = {}
    start = time.perf_counter()
    token = uuid.uuid4().hex[:8]
    with dask_client(scheduler, workers, connect_timeout) as client:
        futures = {client.submit(variant_task, job, key=f"sweep-{job['name']}-{token}",
                                 pure=False, retries=retries): job for job in jobs}
        pending = set(futures)
        while pending:
            try:
                finished, pending = wait(list(pending), timeout=heartbeat_s,
                                         return_when="FIRST_COMPLETED")
            except TimeoutError:  # no variant ended within heartbeat_s: a line anyway
                finished = set()
            pending = set(pending)
            for future in finished:
                job = futures[future]
                try:
                    result = future.result()
                except Exception as error:  # noqa: BLE001 - KilledWorker & co: a row
                    result = _lost(job, error)
                records[job["name"]] = write_variant(out, result, by_name[job["name"]].design)
            counts = {state: sum(r["status"] == state for r in records.values())
                      for state in ("done", "failed", "invalid")}
            running = _running(client, {str(f.key) for f in pending})
            count_line("sweep", {"total": len(jobs), **counts, "running": running,
                                 "queued": len(pending) - running})
    ordered = [records[v.name] for v in found]
    names = columns(parameters)
    rows = [row(r, parameters) for r in ordered]
    summary: dict[str, Any] = {
        "format": FORMAT, "design": str(design), "machine": str(machine),
        "stages": stages, "parameters": parameters, "samples": samples,
        "seed": seed if samples is not None else None,
        "scheduler": scheduler or f"local ({workers} processes)",
        "seconds": round(time.perf_counter() - start, 3),
        "done": sum(r["status"] == "done" for r in ordered),
        "failed": sum(r["status"] == "failed" for r in ordered),
        "invalid": sum(r["status"] == "invalid" for r in ordered),
        "variants": [{k: r.get(k) for k in ("name", "status", "stage", "error", "kind",
                                            "seconds", "worker")} for r in ordered],
    }
    write_csv(out / "sweep.csv", rows, names)
    summary["parquet"] = write_parquet(out / "sweep.parquet", rows, names) or "sweep.parquet"
    write_text_atomic(out / "sweep.json", json.dumps(summary, indent=2) + "\n")
    from cam.run.sweep_html import sweep_html

    write_text_atomic(out / "sweep.html", sweep_html(rows, names, parameters, summary))
    return summary
