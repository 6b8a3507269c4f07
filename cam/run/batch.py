"""``run_batch``: the chain over several specs (design variants) in parallel on Dask.

One Dask task per spec runs ``run_chain`` into ``OUT/<impeller name>/``; a failed
spec is caught in its task and reported (its run.json says which stage failed), the
others go on. ``OUT/batch.json`` summarises: per spec the name, folder, status
(``"done"`` / ``"failed"``), the failed stage, the error and its kind (``"input"``:
exit code 2, ``"internal"``: 1), and the wall time. Local cluster of worker
processes by default; ``scheduler`` connects to a running one instead.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from cam.run.chain import impeller_name, run_chain
from cam.run.record import read_record
from impeller_cam.atomic import write_text_atomic
from impeller_cam.cluster import dask_client
from impeller_cam.errors import InputError

__all__ = ["chain_task", "failure", "run_batch"]


def failure(error: BaseException) -> tuple[str, str]:
    """The message and kind of a task's error: ``"input"`` (an ``InputError``, exit
    code 2: its own message) or ``"internal"`` (1: the exception's type and message)."""
    if isinstance(error, InputError):
        return str(error), "input"
    return f"{type(error).__name__}: {error}", "internal"


def chain_task(spec: str, machine: str, out: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """Run one chain and return its summary; never raises (the task of one spec)."""
    start = time.perf_counter()
    summary: dict[str, Any] = {"spec": spec, "out": out, "status": "done", "stage": None,
                               "error": None, "kind": None}
    try:
        run_chain(spec, machine, out, progress=False, **kwargs)
    except BaseException as error:  # noqa: BLE001 - reported, the batch goes on
        message, kind = failure(error)
        summary.update(status="failed", error=message, kind=kind)
        record = read_record(Path(out))
        if record is not None:
            failed = [s["name"] for s in record["stages"] if s["status"] == "failed"]
            summary["stage"] = failed[0] if failed else None
    summary["seconds"] = round(time.perf_counter() - start, 3)
    return summary


def run_batch(
    specs: list[str | Path],
    machine: str | Path,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    connect_timeout: float = 10.0,
    **kwargs: Any,
) -> dict[str, Any]:
    """Run the chain for every spec in parallel; write OUT/batch.json.

    Parameters
    ----------
    specs : list of str or Path
        Impeller spec TOMLs; their impeller names must differ (one folder each).
    machine : str or Path
        Machine TOML (all specs).
    out : str or Path
        Output folder: ``OUT/<name>/`` per spec and ``OUT/batch.json``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); default a local
        cluster of ``workers`` processes.
    workers : int
        Local worker processes (>= 1).
    connect_timeout : float
        Seconds to wait for ``scheduler``.
    **kwargs
        Passed to every ``run_chain`` (tools, post, only/start, settings).

    Returns
    -------
    dict
        batch.json content: ``specs`` (summaries in the order given), ``done``,
        ``failed``.

    Raises
    ------
    InputError
        No spec, duplicate impeller names, bad workers, unreachable scheduler.
    """
    if not specs:
        raise InputError("no spec given", field="SPEC", accepted="one or more spec TOMLs")
    if workers < 1:
        raise InputError("must be >= 1", field="--workers", value=workers,
                         accepted="a number of local worker processes")
    out = Path(out)
    names: dict[str, str] = {}
    for spec in specs:
        name = impeller_name(spec)
        if name in names:
            raise InputError("two specs have the same impeller name (one folder each)",
                             file=spec, field="impeller.name", value=name,
                             accepted=f"a name other than that of {names[name]}")
        names[name] = str(spec)
    start = time.perf_counter()
    with dask_client(scheduler, workers, connect_timeout) as client:
        futures = [client.submit(chain_task, spec, str(machine), str(out / name), kwargs,
                                 key=f"chain-{name}", pure=False)
                   for name, spec in names.items()]
        results: list[dict[str, Any]] = list(client.gather(futures))
    summary: dict[str, Any] = {
        "format": "impeller-cam batch 1",
        "machine": str(machine),
        "scheduler": scheduler or f"local ({workers} processes)",
        "seconds": round(time.perf_counter() - start, 3),
        "specs": [{"name": name, **result} for name, result in zip(names, results,
                                                                   strict=True)],
    }
    summary["done"] = sum(r["status"] == "done" for r in summary["specs"])
    summary["failed"] = sum(r["status"] == "failed" for r in summary["specs"])
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "batch.json", json.dumps(summary, indent=2) + "\n")
    return summary
