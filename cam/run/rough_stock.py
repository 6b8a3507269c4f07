"""The verified rough stock: made by the finish stage, reused by the verify stage.

Finishing plans against the stock the rough programs really leave (issue 18,
cam/finishing/stock_clearance.py), so the finish stage verifies the rough programs
before it plans (``verify_rough``): it posts the rough APT files as the post stage
will and verifies them on the spec's blank into ``verify/rough/``. The verify stage
then needs the same run; ``reusable_rough`` says whether the one on disk verified
exactly the programs the post stage wrote (byte for byte) with the same tool,
resolution and allowance, and ``stock_deviation`` gives its final stock's deviation
from the design (what ``run_verify`` returns), so that run is not repeated. The
finish stage's run measures that deviation anyway; it is kept beside the stock
(``verify/rough/deviation.npz``, ``cam.verify.deviation.save_deviation``) and read
back when it was made for the same samples and the same design distance, else
measured again.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cam.run.stages import Context, nc_programs, read_json, rough_allowance
from impeller_cam.atomic import replace_path, write_text_atomic

if TYPE_CHECKING:
    from cam.verify.deviation import DesignDistance, Deviation
    from cam.verify.stock import Stock

__all__ = ["DEVIATION", "ROUGH_VERIFY", "RoughStock", "reusable_rough", "stock_deviation",
           "verify_rough"]

#: Where the finish stage leaves the rough verification (relative to the output).
ROUGH_VERIFY = "verify/rough"
#: The deviation of that run's final stock, in its folder (``save_deviation``).
DEVIATION = "deviation.npz"


@dataclass(frozen=True)
class RoughStock:
    """The verified rough stock and the design it was measured against.

    Attributes
    ----------
    path : Path
        ``verify/rough/stock.npz`` (the stock the rough programs leave).
    design : Impeller
        The spec's impeller (``geometry.impeller.Impeller``): finishing reuses its
        solid and meshes (cached) instead of building them again.
    distance : DesignDistance
        Signed distance from ``design.mesh()`` (the verification's design, mm):
        finishing measures the stock's excess material with it.
    """

    path: Path
    design: Any
    distance: DesignDistance


def verify_rough(ctx: Context) -> RoughStock:
    """Post and verify the rough programs on the blank; the verified stock.

    The rough APT files are posted as the post stage will (same dialect and names,
    into ``verify/rough/nc/``) and verified with the roughing tool on the spec's blank
    at ``verify_resolution_mm``, allowance ``rough_allowance``, rendering the last
    stock only (as the verify stage does), into ``verify/rough/`` (replaced as a whole
    on success). The design (the spec's impeller and its signed distance) is built
    once here and handed on with the stock's path, for finishing to reuse.
    """
    from cam.verify.command import VerifyOptions, run_verify
    from cam.verify.deviation import DesignDistance, save_deviation
    from geometry.impeller import Impeller
    from postproc.command import post_text
    from postproc.machine import load_machine
    from postproc.posts import get_post

    dialect = get_post(ctx.settings.post or load_machine(ctx.machine).post)
    rough = read_json(ctx, "rough/rough.json", "rough")
    target = ctx.out / ROUGH_VERIFY
    target.parent.mkdir(parents=True, exist_ok=True)
    design = Impeller.from_spec(ctx.spec)
    mesh = design.mesh()  # run_verify's design mesh (cam.verify.sources.load_design)
    distance = DesignDistance(np.asarray(mesh.vertices, np.float64),
                              np.asarray(mesh.faces, np.int64))
    stage = Path(tempfile.mkdtemp(prefix=".rough-staging-", dir=target.parent))
    try:
        programs = []
        (stage / "nc").mkdir()
        for op in rough["operations"]:
            apt = ctx.out / "rough" / op["apt"]
            nc = stage / "nc" / f"{Path(op['apt']).stem}.{dialect.extension}"
            write_text_atomic(nc, post_text(apt, ctx.machine, post=dialect.name))
            programs.append(nc)
        deviation = run_verify(
            programs, ctx.machine, ctx.settings.rough_tool, str(ctx.spec), ctx.spec,
            ctx.settings.verify_resolution_mm, stage,
            options=VerifyOptions(allowance=rough_allowance(ctx), render_each_program=False,
                                  refuse_short_stock=True),
            progress=False, design_distance=distance)
        if deviation is not None:  # the verify stage reads it back (stock_deviation)
            save_deviation(stage / DEVIATION, deviation, distance)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    replace_path(stage, target)
    return RoughStock(target / "stock.npz", design, distance)


def reusable_rough(ctx: Context) -> Path | None:
    """``verify/rough`` when it verified the post stage's rough programs (byte for byte)
    with this roughing tool, resolution and allowance; else None."""
    folder = ctx.out / ROUGH_VERIFY
    try:
        data = json.loads((folder / "verify.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (folder / "stock.npz").is_file():
        return None
    from cam.tools import resolve_tool

    allowance = data.get("deviation", {}).get("allowance_mm")
    if (data.get("tool") != resolve_tool(ctx.settings.rough_tool).name
            or data.get("resolution_mm") != ctx.settings.verify_resolution_mm
            or allowance is None or abs(float(allowance) - rough_allowance(ctx)) > 1e-12):
        return None
    for program in nc_programs(ctx, "rough"):
        posted = ctx.out / program["nc"]
        mine = folder / "nc" / posted.name
        if not mine.is_file() or mine.read_bytes() != posted.read_bytes():
            return None
    return folder


def stock_deviation(stock: Stock, distance: DesignDistance,
                    saved: Path | None = None) -> Deviation:
    """Surface samples of a stock with their signed design distance and closest design
    face (what ``run_verify`` returns for its final stock).

    ``saved``: a ``save_deviation`` file of this stock (``verify/rough/deviation.npz``);
    read when it was made for these samples and this design distance, else the
    samples are measured.
    """
    from cam.verify.deviation import Deviation, load_deviation

    points, moves = stock.surface_points()
    if saved is not None:
        known = load_deviation(saved, points, moves, distance)
        if known is not None:
            return known
    signed, face = distance.closest(points)
    return Deviation(points, signed, moves, face)
