"""CAM script: rough the small impeller, post it, and verify the program.

1. plan the 3+2 UMR roughing from the spec and a tool of the library into toolpaths
   (``cam.roughing.plan_roughing``, typed ``RoughOptions``);
2. post them for a machine (``postproc.post_toolpaths`` and its dialect's writer);
3. verify the NC program on the spec's lathe-turned blank against the design
   (``cam.verify.run_verify``: gouges, collisions, remaining stock).

Run from anywhere (coarse settings by default: one passage)::

    .venv/bin/python docs/examples/rough_post_verify.py --passages 1 --resolution 0.5

It writes ``rough.ngc`` and the verification (verify.json, report.html) into ``--out``
(default ``out/examples/rough_post_verify``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from cam.roughing import RoughOptions, plan_roughing, roughing_toolpaths
from cam.tools import resolve_tool
from cam.verify import VerifyOptions, run_verify
from geometry import build_surfaces, load_spec
from postproc import PostOptions, get_post, load_machine, post_toolpaths

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


def rough_post_verify(spec: Path, machine_path: Path, tool_name: str, options: RoughOptions,
                      resolution: float, out: Path) -> dict[str, object]:
    """Plan, post and verify the roughing of ``spec``.

    Parameters
    ----------
    spec : Path
        Impeller spec TOML.
    machine_path : Path
        Machine TOML.
    tool_name : str
        Ball-end mill of the tool library.
    options : RoughOptions
        Roughing options (mm, deg).
    resolution : float
        Dexel spacing of the verification, mm.
    out : Path
        Output folder.

    Returns
    -------
    dict
        Toolpaths, poses, NC blocks and the verification's summary (verify.json).
    """
    surfaces = build_surfaces(load_spec(spec))
    tool = resolve_tool(tool_name)
    plan = plan_roughing(surfaces, tool, options)
    toolpaths = roughing_toolpaths(plan)
    machine = load_machine(machine_path)
    post_options = PostOptions()
    posted = post_toolpaths(toolpaths, machine, post_options, source=spec.name)
    dialect = get_post(machine.post)
    out.mkdir(parents=True, exist_ok=True)
    program = out / f"rough.{dialect.extension}"
    program.write_text(dialect.write(posted, post_options))
    run_verify([program], machine_path, tool_name, str(spec), spec, resolution,
               out / "verify", options=VerifyOptions(render=False), progress=False)
    verdict = json.loads((out / "verify" / "verify.json").read_text())
    return {"toolpaths": len(toolpaths), "poses": sum(len(t) for t in toolpaths),
            "umrs": len(plan.umrs), "program": str(program),
            "removed_volume_mm3": verdict["removed_volume_mm3"],
            "events": verdict["event_counts"], "deviation": verdict["deviation"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", type=Path, default=SPEC)
    parser.add_argument("--machine", type=Path, default=MACHINE)
    parser.add_argument("--tool", default="ball6")
    parser.add_argument("--passages", type=int, default=1, help="passages to cut (0: all)")
    parser.add_argument("--resolution", type=float, default=0.5, help="dexel spacing, mm")
    parser.add_argument("--out", type=Path,
                        default=ROOT / "out" / "examples" / "rough_post_verify")
    args = parser.parse_args()
    options = RoughOptions(passages=args.passages, design="surfaces", step_along_mm=2.0,
                           scallop_mm=1.0)
    summary = rough_post_verify(args.spec, args.machine, args.tool, options,
                                args.resolution, args.out)
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
