"""Machine TOML: the fixtures, unit conversion, limit checks and bad input."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from impeller_cam.errors import InputError
from postproc.kinematics import OverTravelError
from postproc.machine import (
    SERVO_KEYS,
    AxisSpec,
    Machine,
    PivotOffsets,
    TableGeometry,
    ideal_machine,
    load_machine,
)

MACHINES = Path(__file__).resolve().parents[2] / "fixtures" / "machines"
XYZAC = MACHINES / "xyzac-trt.toml"
TRUNNION = MACHINES / "trunnion-500.toml"


def test_xyzac_trt_fixture_mirrors_the_linuxcnc_sim() -> None:
    machine = load_machine(XYZAC)
    assert machine.kinematics == "xyzac-trt"
    assert machine.axis_names == ("X", "Y", "Z", "A", "C")
    assert machine.pivot == PivotOffsets(y_offset=20.0, z_offset=10.0)
    assert not machine.conventional_directions
    assert machine.tcp and machine.post == "linuxcnc" and machine.table is None
    assert machine.source == XYZAC
    lower, upper = machine.limits()
    np.testing.assert_allclose(
        lower, [-200.0, -100.0, -120.0, math.radians(-100.0), math.radians(-36000.0)]
    )
    np.testing.assert_allclose(
        upper, [200.0, 100.0, 120.0, math.radians(50.0), math.radians(36000.0)]
    )
    x, a = machine.axes["X"], machine.axes["A"]
    assert (x.rotary, a.rotary) == (False, True)
    assert x.velocity == pytest.approx(20.0)  # 1200 mm/min -> mm/s
    assert a.velocity == pytest.approx(math.radians(30.0))  # 1800 deg/min -> rad/s
    assert a.acceleration == pytest.approx(math.radians(300.0))
    assert math.isinf(x.jerk) and dict(x.servo) == {}


def test_trunnion_fixture() -> None:
    machine = load_machine(TRUNNION)
    assert machine.conventional_directions and machine.tcp
    assert machine.pivot.z_offset == 50.0
    # the part stands on a 100 mm riser (the machine model's fixture)
    assert machine.table == TableGeometry(radius=250.0, height=60.0, z_top=-100.0)
    c = machine.axes["C"]
    assert c.continuous and c.minimum == -math.inf and c.maximum == math.inf
    assert c.velocity == pytest.approx(math.radians(180.0))
    assert c.jerk == pytest.approx(math.radians(18000.0))
    assert c.servo["torque_limit"] == 725.0 and c.servo["Kpp"] == 60.0
    assert machine.axes["X"].servo["screw_lead"] == 16.0
    a = machine.axes["A"]
    assert (math.degrees(a.minimum), math.degrees(a.maximum)) == pytest.approx((-120.0, 30.0))
    assert set(machine.axes["C"].servo) <= set(SERVO_KEYS)


def test_check_limits_names_first_row_axis_value_limit() -> None:
    machine = load_machine(XYZAC)
    joints = np.zeros((4, 5))
    joints[2, 1] = 100.5  # Y > 100 mm
    joints[3, 3] = math.radians(-101.0)  # A < -100 deg (a later row)
    with pytest.raises(OverTravelError) as caught:
        machine.check_limits(joints, records=np.array([7, 8, 9, 10]))
    error = caught.value
    assert (error.index, error.record, error.axis, error.unit) == (2, 9, "Y", "mm")
    assert (error.value, error.limit) == (pytest.approx(100.5), 100.0)
    joints[2, 1] = 0.0
    with pytest.raises(OverTravelError) as caught:
        machine.check_limits(joints)
    error = caught.value
    assert (error.index, error.record, error.axis, error.unit) == (3, None, "A", "deg")
    assert error.value == pytest.approx(-101.0) and error.limit == pytest.approx(-100.0)
    assert re.search(
        r"pose 3: axis A would have to reach -101\.0+ deg, beyond its minimum "
        r"-100\.0+ deg; accepted: A in \[-100, 50\] deg",
        str(error),
    )


def test_check_limits_accepts_the_limits_themselves() -> None:
    machine = load_machine(XYZAC)
    lower, upper = machine.limits()
    machine.check_limits(np.vstack([lower, upper, np.zeros(5)]))


def test_check_limits_rejects_nan() -> None:
    machine = load_machine(XYZAC)
    joints = np.zeros((2, 5))
    joints[1, 4] = np.nan
    with pytest.raises(InputError, match="pose 1: axis C is not a number"):
        machine.check_limits(joints)


def test_ideal_machine_with_some_limits() -> None:
    machine = ideal_machine("xyzbc-trt", limits={"B": (-1.0, 1.0)})
    assert machine.axis_names == ("X", "Y", "Z", "B", "C")
    assert machine.axes["B"].minimum == -1.0 and math.isinf(machine.axes["X"].maximum)
    with pytest.raises(ValueError, match="no axis"):
        ideal_machine("xyzbc-trt", limits={"A": (-1.0, 1.0)})


def test_machine_is_frozen() -> None:
    machine = load_machine(XYZAC)
    with pytest.raises(AttributeError):
        machine.name = "other"  # type: ignore[misc]
    with pytest.raises(TypeError):
        machine.axes["X"] = machine.axes["Y"]  # type: ignore[index]
    assert isinstance(machine, Machine) and isinstance(machine.axes["X"], AxisSpec)


# ------------------------------------------------------------------ bad input
def _edit(tmp_path: Path, old: str, new: str, source: Path = XYZAC) -> Path:
    text = source.read_text()
    assert old in text, old
    path = tmp_path / "machine.toml"
    path.write_text(text.replace(old, new, 1))
    return path


BAD_EDITS = [
    # (old text, new text, field named in the error, words of the message)
    ('kinematics = "xyzac-trt"', 'kinematics = "hexapod"', "kinematics", "unknown kinematics"),
    ('kinematics = "xyzac-trt"', "", "kinematics", "is required"),
    ('name = "LinuxCNC sim xyzac-trt"', "name = 3", "name", "non-empty string"),
    ("tcp = true", 'tcp = "yes"', "tcp", "true or false"),
    ("y_offset = 20.0", 'y_offset = "20"', "pivot.y_offset", "must be a number"),
    ("y_offset = 20.0", "y_ofset = 20.0", "pivot.y_ofset", "unknown key"),
    ("[axes.C]\nmin = -36000.0", "[axes.B]\nmin = -36000.0", "axes.B", "unknown key"),
    ("min = -200.0", "min = 250.0", "axes.X.max", "min must be below max"),
    ("min = -200.0", "min = -inf", "axes.X.min", "finite number"),
    ("min = -200.0", "", "axes.X.min", "is required"),
    ("velocity = 1200.0      # 20 mm/s", "velocity = 0", "axes.X.velocity", "positive"),
    (
        "acceleration = 300.0\n\n[axes.Y]",
        "acceleration = -1\n\n[axes.Y]",
        "axes.X.acceleration",
        "positive",
    ),
    (
        "acceleration = 300.0\n\n[axes.Y]",
        "acceleration = 300.0\njerk = true\n\n[axes.Y]",
        "axes.X.jerk",
        "must be a number",
    ),
    (
        "acceleration = 300.0\n\n[axes.Y]",
        "acceleration = 300.0\ncontinuous = true\n\n[axes.Y]",
        "axes.X.continuous",
        "only a rotary axis",
    ),
    (
        "[axes.C]\nmin = -36000.0",
        "[axes.C]\ncontinuous = true\nmin = -36000.0",
        "axes.C.min",
        "no travel limit",
    ),
    (
        "acceleration = 300.0\n\n[axes.Y]",
        "acceleration = 300.0\nservo = { Kp = 1.0 }\n\n[axes.Y]",
        "axes.X.servo.Kp",
        "unknown key",
    ),
    (
        "acceleration = 300.0\n\n[axes.Y]",
        "acceleration = 300.0\nservo = { Kpp = -1.0 }\n\n[axes.Y]",
        "axes.X.servo.Kpp",
        "must not be negative",
    ),
    ("[pivot]", "table = { radius = 0.0, height = 10.0 }\n\n[pivot]", "table.radius", "positive"),
    ("[pivot]", "colour = 1\n\n[pivot]", "colour", "unknown key"),
]


@pytest.mark.parametrize(("old", "new", "field", "words"), BAD_EDITS)
def test_bad_field_is_named(tmp_path: Path, old: str, new: str, field: str, words: str) -> None:
    path = _edit(tmp_path, old, new)
    with pytest.raises(InputError) as caught:
        load_machine(path)
    error = caught.value
    assert error.field == field
    assert words in str(error)
    assert str(path) in str(error)


def test_missing_axis(tmp_path: Path) -> None:
    text = XYZAC.read_text()
    head, _, _ = text.partition("[axes.C]")
    path = tmp_path / "machine.toml"
    path.write_text(head)
    with pytest.raises(InputError, match="needs axis C") as caught:
        load_machine(path)
    assert caught.value.field == "axes.C"


def test_not_toml_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("name = \n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_machine(path)
    with pytest.raises(InputError, match="not found"):
        load_machine(tmp_path / "absent.toml")


def test_rotary_infinite_limits_are_accepted(tmp_path: Path) -> None:
    path = _edit(
        tmp_path, "[axes.C]\nmin = -36000.0\nmax = 36000.0", "[axes.C]\nmin = -inf\nmax = inf"
    )
    assert load_machine(path).axes["C"].continuous
