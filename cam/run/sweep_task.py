"""The Dask task of one sweep variant: self-contained, no shared filesystem.

``variant_task(job)`` gets everything it reads in ``job`` (the design as a dict, the
machine file's text, the tool library's text when one is given) and works in a
temporary folder of its own (``tempfile``: the worker's, whatever its working
folder), removed at the end. It

1. writes ``design.toml`` and runs the design generator as ``impeller-cam design``
   does (schema, ranges, ``[machining]`` options, generation, clearances: blades
   touching, fillet too large); a refusal makes the variant ``"invalid"`` with the
   message;
2. runs the chain's stages (``cam.run.chain.run_chain``) into ``run/``; a failing
   stage makes the variant ``"failed"`` (stage, message, kind ``"input"`` or
   ``"internal"``), the figures of the stages before it are kept;
3. returns a JSON-ready summary (``cam.run.sweep_figures``) and the files as bytes
   (``files``: ``"json"`` the design, spec and every JSON file; ``"all"`` every file),
   keyed by their path in the variant's folder.

It never raises for a variant's own failure, so one variant cannot stop the others;
a worker that dies is the scheduler's business (it reruns the task elsewhere).
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["FILE_MODES", "SWEEP_STAGES", "chain_stages", "variant_task"]

#: ``--stages`` choices: the last stage run (``design``: the generator's figures only).
SWEEP_STAGES = ("design", "geometry", "rough", "finish", "all")
#: ``--files`` choices.
FILE_MODES = ("json", "all")


def chain_stages(stages: str) -> list[str]:
    """The chain stages of a ``--stages`` choice, in order."""
    from cam.run.record import STAGES

    if stages not in SWEEP_STAGES:
        raise InputError("unknown stage", field="--stages", value=stages,
                         accepted=", ".join(SWEEP_STAGES))
    if stages == "all":
        return list(STAGES)
    return list(STAGES[:STAGES.index(stages) + 1]) if stages != "design" else []


def _generate(design: Path, spec_folder: Path) -> Path:
    """The design generator (``impeller-cam design``): spec.toml, CSVs, figures.json."""
    import json
    import tomllib

    from cam.inputs import check_options
    from geometry.design import generate, load_design
    from geometry.design_files import write_generated
    from geometry.design_summary import design_figures
    from geometry.machining import read_machining

    params = load_design(design)
    check_options(read_machining(tomllib.loads(params.machining_toml)), design)
    generated = generate(params)
    figures = design_figures(generated)
    text = json.dumps(figures, indent=2, sort_keys=True) + "\n"
    return write_generated(generated, spec_folder, extra={"figures.json": text})


def _run_settings(job: dict[str, Any], library: Path | None) -> dict[str, Any]:
    """``run_chain`` keywords; with a shipped library every tool name points into it."""
    settings = dict(job.get("settings") or {})
    if library is None:
        return settings
    machining = job["design"].get("machining", {})
    tool = settings.pop("tool", None)
    for key in ("rough_tool", "finish_tool"):
        name = settings.get(key) or tool or machining.get(key)
        if name:
            settings[key] = f"{library}:{name}"
    name = settings.get("fillet_tool") or machining.get("fillet_tool")
    if name:
        settings["fillet_tool"] = f"{library}:{name}"
    return settings


def _collect(folder: Path, mode: str) -> dict[str, bytes]:
    """Files of the variant folder (relative POSIX path -> bytes), hidden ones left out."""
    files: dict[str, bytes] = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder)
        if not path.is_file() or any(part.startswith(".") for part in rel.parts):
            continue
        keep = mode == "all" or path.suffix in (".json", ".toml", ".csv")
        if keep:
            files[rel.as_posix()] = path.read_bytes()
    return files


def variant_task(job: dict[str, Any]) -> dict[str, Any]:
    """Generate, check and run one variant; return its summary and files.

    Parameters
    ----------
    job : dict
        ``name``, ``parameters`` (path -> value), ``design`` (the design TOML as a
        dict), ``machine`` (``{"name", "text"}``), ``library`` (``{"name", "text"}``
        or None), ``stages`` (a ``SWEEP_STAGES`` choice), ``settings`` (``run_chain``
        keywords), ``files`` (a ``FILE_MODES`` choice).

    Returns
    -------
    dict
        ``name``, ``parameters``, ``status`` (``"done"``, ``"invalid"``, ``"failed"``),
        ``stage`` (where it stopped), ``error``, ``kind``, ``figures``
        (``variant_figures``), ``seconds``, ``worker`` (host:pid), ``files``.
    """
    import tomli_w

    from cam.run.batch import failure
    from cam.run.chain import run_chain
    from cam.run.sweep_figures import variant_figures

    start = time.perf_counter()
    result: dict[str, Any] = {"name": job["name"], "parameters": job["parameters"],
                              "stages": job["stages"], "status": "done", "stage": None,
                              "error": None, "kind": None, "figures": None,
                              "worker": f"{socket.gethostname()}:{os.getpid()}"}
    root = Path(tempfile.mkdtemp(prefix=f"impeller-sweep-{job['name']}-"))
    variant = root / "variant"
    try:
        variant.mkdir()
        design = variant / "design.toml"
        design.write_text(tomli_w.dumps(job["design"]), encoding="utf-8")
        machine = root / job["machine"]["name"]
        machine.write_text(job["machine"]["text"], encoding="utf-8")
        library = None
        if job.get("library"):
            library = root / job["library"]["name"]
            library.write_text(job["library"]["text"], encoding="utf-8")
        settings = _run_settings(job, library)
        try:
            spec = _generate(design, variant / "spec")
        except Exception as error:  # noqa: BLE001 - an invalid variant is a row
            message, kind = failure(error)
            result.update(status="invalid", stage="design", error=message, kind=kind)
            spec = None
        if spec is not None:
            for stage in chain_stages(job["stages"]):
                try:
                    run_chain(spec, machine, variant / "run", only=stage, progress=False,
                              **settings)
                except Exception as error:  # noqa: BLE001 - a failed variant is a row
                    message, kind = failure(error)
                    result.update(status="failed", stage=stage, error=message, kind=kind)
                    if kind == "internal":
                        result["traceback"] = traceback.format_exc(limit=8)
                    break
            try:
                result["figures"] = variant_figures(variant / "spec", variant / "run",
                                                    machine, settings.get("post"), library)
            except Exception as error:  # noqa: BLE001 - reported with the variant
                message, kind = failure(error)
                result.update(status="failed", stage=result["stage"] or "figures",
                              error=result["error"] or message, kind=result["kind"] or kind)
        result["files"] = _collect(variant, job.get("files", "json"))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    result["seconds"] = round(time.perf_counter() - start, 3)
    return result
