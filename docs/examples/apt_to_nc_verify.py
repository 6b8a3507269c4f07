"""CAM script: a third-party APT CLDATA file to an NC program, verified.

A CATIA-style APT file (``fixtures/apt/catia_style_isoparametric.apt``: a 6 mm ball,
five-axis isoparametric passes over the top of a part) is read into toolpaths
(``postproc.read_apt``), posted for a machine (``postproc.post_toolpaths`` and the
machine's dialect), and the NC program is cut on a cylindrical stock
(``cam.verify.run_verify``; no design: the removed volume and the events only).

Run from anywhere::

    .venv/bin/python docs/examples/apt_to_nc_verify.py --resolution 0.5

It writes the NC program and the verification into ``--out``
(default ``out/examples/apt_to_nc_verify``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from cam.verify import VerifyOptions, run_verify
from postproc import PostOptions, get_post, load_machine, post_toolpaths, read_apt

ROOT = Path(__file__).resolve().parents[2]
APT = ROOT / "fixtures" / "apt" / "catia_style_isoparametric.apt"
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


def apt_to_nc_verify(apt: Path, machine_path: Path, tool: str, stock: str,
                     resolution: float, out: Path) -> dict[str, object]:
    """Post a third-party APT file and verify the program on a stock.

    Parameters
    ----------
    apt : Path
        APT CLDATA file (poses in the workpiece frame, mm or inch as it declares).
    machine_path : Path
        Machine TOML.
    tool : str
        The tool of the library matching the APT's cutter.
    stock : str
        ``cylinder:D,H`` (mm) or any ``impeller-cam verify --stock`` argument.
    resolution : float
        Dexel spacing of the verification, mm.
    out : Path
        Output folder.

    Returns
    -------
    dict
        Operations, NC blocks and the verification's summary (verify.json).
    """
    toolpaths = read_apt(apt)
    machine = load_machine(machine_path)
    options = PostOptions(chordal_tolerance=0.01)
    posted = post_toolpaths(toolpaths, machine, options, source=apt.name)
    dialect = get_post(machine.post)
    out.mkdir(parents=True, exist_ok=True)
    program = out / f"{apt.stem}.{dialect.extension}"
    program.write_text(dialect.write(posted, options))
    run_verify([program], machine_path, tool, stock, None, resolution, out / "verify",
               options=VerifyOptions(render=False), progress=False)
    verdict = json.loads((out / "verify" / "verify.json").read_text())
    return {"operations": [t.name for t in toolpaths], "program": str(program),
            "removed_volume_mm3": verdict["removed_volume_mm3"],
            "events": verdict["event_counts"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--apt", type=Path, default=APT)
    parser.add_argument("--machine", type=Path, default=MACHINE)
    parser.add_argument("--tool", default="ball6")
    parser.add_argument("--stock", default="cylinder:100,62", help="cylinder:D,H, mm")
    parser.add_argument("--resolution", type=float, default=0.5, help="dexel spacing, mm")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "examples" / "apt_to_nc_verify")
    args = parser.parse_args()
    summary = apt_to_nc_verify(args.apt, args.machine, args.tool, args.stock,
                               args.resolution, args.out)
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
