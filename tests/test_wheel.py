"""The package works outside its repository: build the wheel, install it, run the chain.

The sources are copied to a temporary folder and built there with
``pip wheel --no-build-isolation`` (offline: the project's venv has setuptools and
wheel), installed with ``--no-deps`` into a fresh venv whose only view of the
dependencies is the project venv's site-packages (a ``.pth`` line: the editable
install of the repository is not activated). Everything then runs in a folder outside
the repository without ``PYTHONPATH``: the bundled example impeller, the bundled
machine, the bundled tool library and indexing plant. The chain on the small example
runs every stage with the chain test's coarse settings on one passage (roughed and
finished): what is under test is that the installed package finds its data and runs
each stage to the report, not the passages (the whole chain on every passage is
``tests/cam/run/test_chain.py``). Still a minute or two: marked ``slow``.

The numba kernels are not compiled a second time: the checkout's compiled kernels
(``__pycache__/*.nbi``, ``*.nbc``: ``scripts/test`` compiles them before the tests,
``tests/warm_kernels.py``) are copied beside the installed modules. numba keys a cached
kernel on its module's name, the function's line and the sha256 of the source file's
bytes, which the wheel leaves as they are, so the installed package loads them from its
own ``__pycache__``; a kernel the checkout has not compiled (a cold checkout: none) the
installed package compiles itself, as a user's first run does.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("impeller_cam", "geometry", "cam", "postproc")
#: The chain test's coarse settings (tests/cam/conftest.py), one passage roughed and
#: finished, written into the example.
COARSE = """[machining]
rough_tool = "ball6"
finish_tool = "ball4_taper"
verify_resolution_mm = 0.3
tessellation_mm = 0.05

[machining.rough]
scallop_mm = 1.0
step_along_mm = 2.0
passages = 1

[machining.finish]
scallop_mm = 0.8
point_spacing_mm = 1.5
passages = 1
"""


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _run(args: list[str], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(args, cwd=cwd, env=_env(), capture_output=True, text=True,
                          timeout=timeout, check=False)
    assert done.returncode == 0, f"{args}\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv with the wheel installed; returns its bin folder."""
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copyfile(ROOT / name, src / name)
    for package in PACKAGES:
        shutil.copytree(ROOT / package, src / package,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
          "--no-index", "-q", "-w", str(base / "dist"), str(src)], base, timeout=300)
    wheel = next((base / "dist").glob("impeller_cam-*.whl"))
    venv = base / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], base)
    python = venv / "bin" / "python"
    target = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                  base).stdout.strip()
    (Path(target) / "project-dependencies.pth").write_text(site.getsitepackages()[0] + "\n")
    _run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)],
         base, timeout=300)
    copy_compiled_kernels(Path(target))
    return venv / "bin"


def copy_compiled_kernels(target: Path) -> int:
    """Copy the checkout's compiled numba kernels (``__pycache__/*.nbi``, ``*.nbc``)
    beside the modules installed under ``target`` (site-packages); returns how many
    files were copied (module docstring)."""
    copied = 0
    for package in PACKAGES:
        for cached in sorted((ROOT / package).rglob("__pycache__/*.nb[ic]")):
            source = cached.parent.parent
            if not (target / source.relative_to(ROOT)).is_dir():
                continue  # a folder the wheel does not hold
            folder = target / cached.parent.relative_to(ROOT)
            folder.mkdir(exist_ok=True)
            shutil.copyfile(cached, folder / cached.name)
            copied += 1
    return copied


@pytest.mark.slow
def test_wheel_holds_the_data_and_imports_from_the_venv(installed: Path,
                                                        tmp_path: Path) -> None:
    where = _run([str(installed / "python"), "-c",
                  "import cam, impeller_cam.data as d; print(cam.__file__); "
                  "print(d.data_path('tools', 'library.toml'))"], tmp_path).stdout.split()
    venv = installed.parent.resolve()
    assert all(Path(p).resolve().is_relative_to(venv) for p in where), where
    assert not any(str(ROOT) in p for p in where)
    cli = str(installed / "impeller-cam")
    assert _run([cli, "--version"], tmp_path).stdout.startswith("impeller-cam ")
    assert "ball6_taper" in _run([cli, "tools"], tmp_path).stdout
    schemas = _run([str(installed / "python"), "-c",
                    "from importlib.resources import files; print(sorted(p.name for p in "
                    "files('impeller_cam').joinpath('schemas').iterdir()))"], tmp_path).stdout
    assert "spec.schema.json" in schemas and "tools.schema.json" in schemas


@pytest.mark.slow
def test_run_on_the_small_example_outside_the_repository(installed: Path,
                                                         tmp_path: Path) -> None:
    cli = str(installed / "impeller-cam")
    _run([cli, "example", "small", "-o", "small"], tmp_path)
    spec = tmp_path / "small" / "spec.toml"
    spec.write_text(spec.read_text().split("[machining]")[0] + COARSE)
    _run([cli, "check", str(spec)], tmp_path)
    # trunnion-500 without its [model]: the small part does not fit that machine with
    # the library's short tools (tests/cam/conftest.py)
    from tests.cam.conftest import TRUNNION, without_model

    _run([cli, "run", "small/spec.toml", "-m", str(without_model(TRUNNION)), "-o", "out"],
         tmp_path, timeout=1800)
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    stages = {entry["name"]: entry["status"] for entry in record["stages"]}
    assert stages and set(stages.values()) == {"done"}, stages
    assert (tmp_path / "out" / "report.html").is_file()
    assert record["settings"]["finish"]["passages"] == 1  # the example's [machining] read
    post = json.loads((tmp_path / "out" / "nc" / "post.json").read_text())
    assert {p["operation"] for p in post["programs"]} == {"rough", "finish"}
    assert all((tmp_path / "out" / p["nc"]).is_file() for p in post["programs"])
    motion = json.loads((tmp_path / "out" / "motion" / "motion.json").read_text())
    assert motion["indexing"].get("optimisation") is not None  # the bundled plant was read
