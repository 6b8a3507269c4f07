"""Fuzz: every input kind, perturbed, is refused with one message and never a traceback.

Hypothesis (derandomized) perturbs a fixture of each kind: delete a key, rename a key
by one letter, give a wrong type, a NaN, a negative number, or duplicate a table or
key line. ``cam.inputs.check_file`` (the readers the commands use, loaders only: no
chain) must either accept the file or raise ``InputError`` with a one-line message;
renames, wrong types, NaN, duplicates and negative lengths must be refused. At least
200 cases per kind. One CLI-level case per kind checks exit code 2 and that no output
was written.
"""

from __future__ import annotations

import copy
import math
import shutil
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
import tomli_w
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from cam.cli import main
from cam.inputs import KINDS, check_file, schemas
from impeller_cam.errors import InputError
from impeller_cam.options import options_model

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "fixtures"
CASES = 200
SOURCES = {
    "spec": FIXTURES / "impellers" / "small" / "spec.toml",
    "machining": FIXTURES / "impellers" / "nine_blade" / "spec.toml",
    "design": FIXTURES / "impellers" / "small" / "design.toml",
    "machine": FIXTURES / "machines" / "trunnion-500.toml",
    "tools": FIXTURES / "tools" / "library.toml",
    "plant": FIXTURES / "motion" / "indexing_table.toml",
    "feed-drive": FIXTURES / "motion" / "suzuki_table1.toml",
}
OPERATIONS = ("delete", "rename", "wrong_type", "nan", "negative", "duplicate")
MUST_REFUSE = {"rename", "wrong_type", "nan", "duplicate"}


def _names(schema: Any, out: set[str]) -> set[str]:
    """Every key any schema declares (a rename onto one of them is not a typo)."""
    if isinstance(schema, dict):
        out.update(schema.get("properties", {}))
        for value in schema.values():
            _names(value, out)
    elif isinstance(schema, list):
        for value in schema:
            _names(value, out)
    return out


def _known() -> set[str]:
    from cam.finishing.options import FinishOptions
    from cam.roughing.options import RoughOptions

    names = _names(schemas(), set())
    for options in (RoughOptions, FinishOptions):
        names |= set(options_model(options).model_fields)
    return names


KNOWN = _known()


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a parsed document, list entries included."""
    out: list[tuple[Any, ...]] = []
    items = node.items() if isinstance(node, dict) else (
        enumerate(node) if isinstance(node, list) else ())
    for key, value in items:
        out.append((*prefix, key))
        out.extend(_paths(value, (*prefix, key)))
    return out


def _wrong(value: Any) -> Any:
    """A value of another type than ``value``."""
    if isinstance(value, bool):
        return "yes"
    if isinstance(value, int | float):
        return str(value)
    if isinstance(value, str):
        return 1
    if isinstance(value, dict):
        return 1.0
    return "x"


def _mutate_key(key: str, position: int, letter: str, how: int) -> str:
    i = position % (len(key) + 1)
    if how == 0:
        return key[:i] + letter + key[i:]
    if how == 1 and key:
        i = min(i, len(key) - 1)
        return key[:i] + letter + key[i + 1:]
    return key[:i] + key[i + 1:] if key else letter


def _perturb(text: str, data: dict[str, Any], kind: str, op: str, pick: int, position: int,
             letter: str, how: int) -> tuple[str, bool]:
    """Perturbed TOML text and whether it must be refused."""
    if op == "duplicate":
        lines = text.splitlines()
        candidates = [i for i, line in enumerate(lines)
                      if line.startswith("[") or ("=" in line and not line.startswith("#")
                                                  and not line.startswith(" "))]
        at = candidates[pick % len(candidates)]
        lines.insert(at + 1, lines[at])
        return "\n".join(lines) + "\n", True
    paths = _paths(data)
    if kind == "machining":
        paths = [p for p in paths if p[0] == "machining"]
    path = paths[pick % len(paths)]
    doc = copy.deepcopy(data)
    parent = doc
    for part in path[:-1]:
        parent = parent[part]
    key = path[-1]
    value = parent[key]
    refuse = op in MUST_REFUSE
    if op == "delete":
        del parent[key]
    elif op == "rename":
        assume(isinstance(key, str))
        new = _mutate_key(key, position, letter, how)
        assume(new != key and new not in KNOWN and new not in parent)
        parent[new] = parent.pop(key)
    elif op == "wrong_type":
        parent[key] = _wrong(value)
    elif op == "nan":
        parent[key] = math.nan
    else:  # negative
        assume(isinstance(value, int | float) and not isinstance(value, bool))
        parent[key] = -value
        refuse = isinstance(key, str) and key.endswith("_mm") and value > 0
    return tomli_w.dumps(doc), refuse


def _folder(tmp: Path, kind: str) -> Path:
    """A copy of the fixture's folder (the spec's CSVs), returns the file to write."""
    source = SOURCES[kind]
    for csv in source.parent.glob("*.csv"):
        shutil.copyfile(csv, tmp / csv.name)
    return tmp / source.name


@pytest.mark.parametrize("kind", sorted(SOURCES))
def test_perturbed_inputs_are_refused_cleanly(kind: str, tmp_path: Path) -> None:
    text = SOURCES[kind].read_text()
    data = tomllib.loads(text)
    target = _folder(tmp_path, kind)
    check_kind = "spec" if kind == "machining" else kind
    before = sorted({target.name, *(p.name for p in tmp_path.iterdir())})
    counts: Counter[str] = Counter()

    @settings(max_examples=CASES, derandomize=True, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
    @given(op=st.sampled_from(OPERATIONS), pick=st.integers(0, 10_000),
           position=st.integers(0, 40), letter=st.sampled_from("aeiklmnorstx_"),
           how=st.integers(0, 2))
    def case(op: str, pick: int, position: int, letter: str, how: int) -> None:
        perturbed, refuse = _perturb(text, data, kind, op, pick, position, letter, how)
        target.write_text(perturbed)
        counts[op] += 1
        try:
            check_file(target, check_kind)
        except InputError as error:
            message = str(error)
            assert message and "\n" not in message and str(target) in message
            counts["refused"] += 1
        else:
            assert not refuse, f"{op} accepted:\n{perturbed}"

    case()
    print(kind, dict(counts))  # shown with pytest -s: cases per operation, refused
    assert sum(counts[op] for op in OPERATIONS) >= CASES, counts
    assert all(counts[op] for op in OPERATIONS), counts
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing else written


def _bad(tmp_path: Path, kind: str, old: str, new: str) -> Path:
    target = _folder(tmp_path, kind)
    text = SOURCES[kind].read_text()
    assert old in text
    target.write_text(text.replace(old, new, 1))
    return target


CLI_CASES = {
    "spec": ("fillet_radius_mm", "fillet_radus_mm", ["geometry", "{bad}", "-o", "{out}"]),
    "machining": ("scallop_mm = 0.5", "scallop_mm = nan",
                  ["run", "{bad}", "-m", "trunnion-500", "-o", "{out}"]),
    "design": ("bore_radius_mm", "bore_radius", ["design", "{bad}", "-o", "{out}"]),
    "machine": ("[axes.X]", "[axes.X]\nvelocty = 1.0",
                ["post", str(FIXTURES / "apt" / "post_impeller_ops.apt"), "-m", "{bad}", "-o",
                 "{out}/p.ngc"]),
    "tools": ("[[tool.holder]]", "[[tool.holdr]]",
              ["rough", str(SOURCES["spec"]), "-m", "trunnion-500", "-t", "{bad}:ball10",
               "-o", "{out}"]),
    "plant": ("stiffness = 730000.0", "stifness = 730000.0",
              ["motion", "optimize", "--plant", "{bad}", "--stroke", "20", "--plots",
               "{out}"]),
    "feed-drive": ("Kvi = 0.198", "Kvi = -0.198", ["check", "{bad}"]),
}


@pytest.mark.parametrize("kind", sorted(CLI_CASES))
def test_commands_exit_2_and_write_nothing(kind: str, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    old, new, argv = CLI_CASES[kind]
    bad = _bad(tmp_path, kind, old, new)
    out = tmp_path / "out"
    args = [a.replace("{bad}", str(bad)).replace("{out}", str(out)) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("impeller-cam: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and str(bad) in err
    assert not out.exists()


def test_every_kind_is_fuzzed() -> None:
    assert {"machining", *KINDS} == set(SOURCES)
