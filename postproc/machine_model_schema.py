"""Declaration of a machine file's ``[model]`` table: the machine's own solids.

Keys, units (mm) and ranges of the components, the fixture and the pair rules;
``postproc.machine_model.model_from_table`` checks what depends on the kinematics
(which axes) and on other files (STL meshes). Format: docs/machine-model.md.
"""

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from impeller_cam.schema import Strict, quantity

__all__ = ["ComponentTable", "FixtureTable", "ModelTable", "PairTable"]

#: What a component may be attached to: the machine base, a joint of the kinematics.
ATTACH_WORDS = ("base", "X", "Y", "Z", "A", "B", "C")


class ComponentTable(Strict):
    """``[[model.component]]``: one solid attached to one group of the chain.

    A box needs ``size``; a cylinder ``radius`` and ``length``; a cone (frustum)
    ``radius``, ``top_radius`` and ``length``; an STL ``file``.
    """

    name: str = quantity(min_length=1, description="unique component name")
    axis: str = quantity(min_length=1,
                         description="what moves it: base, X, Y, Z (spindle head), A/B, C")
    shape: Literal["box", "cylinder", "cone", "stl"] = quantity(description="solid kind")
    size: list[float] | None = quantity(
        None, unit="mm", min_length=3, max_length=3,
        description="box edge lengths along x, y, z")
    radius: float | None = quantity(None, unit="mm", description="cylinder or cone base radius")
    top_radius: float | None = quantity(None, unit="mm", description="cone radius at its top")
    length: float | None = quantity(None, unit="mm", description="cylinder or cone length")
    along: Literal["x", "y", "z"] = quantity("z", description="cylinder or cone axis")
    at: list[float] = quantity(
        [0.0, 0.0, 0.0], unit="mm", min_length=3, max_length=3,
        description="centre of the solid in its axis frame")
    file: str | None = quantity(None, description="STL mesh, relative to the machine file")

    @model_validator(mode="after")
    def _sizes(self) -> ComponentTable:
        needs = {"box": ("size",), "cylinder": ("radius", "length"),
                 "cone": ("radius", "top_radius", "length"), "stl": ("file",)}[self.shape]
        for key in needs:
            if getattr(self, key) is None:
                raise ValueError(f"a {self.shape} needs {key!r} ({', '.join(needs)})")
        for key in ("radius", "length"):
            value = getattr(self, key)
            if value is not None and not value > 0:
                raise ValueError(f"{key} must be > 0 mm, got {value}")
        if self.top_radius is not None and self.top_radius < 0:
            raise ValueError(f"top_radius must be >= 0 mm, got {self.top_radius}")
        if self.size is not None and not min(self.size) > 0:
            raise ValueError(f"every box size must be > 0 mm, got {list(self.size)}")
        return self


class FixtureTable(Strict):
    """``[model.fixture]``: what holds the blank on the rotary table (axis C).

    ``mandrel``: a shaft of ``diameter`` through the bore, clamped by a nut of
    ``nut_diameter`` x ``nut_height`` on the part's top face, the part standing on a
    riser of ``riser_diameter`` x ``height`` (0: on the table). ``chuck``: a body of
    ``diameter`` x ``height`` under the part with three jaws ``jaw_width`` wide
    gripping the part's rim up to ``jaw_height`` above its bottom face.
    """

    kind: Literal["mandrel", "chuck"] = quantity(description="mandrel or chuck")
    diameter: float = quantity(unit="mm", gt=0, description="shaft or chuck body diameter")
    height: float = quantity(0.0, unit="mm", ge=0, description="riser or chuck body height")
    riser_diameter: float = quantity(0.0, unit="mm", ge=0, description="mandrel riser diameter")
    nut_diameter: float = quantity(0.0, unit="mm", ge=0, description="mandrel nut diameter")
    nut_height: float = quantity(0.0, unit="mm", ge=0, description="mandrel nut height")
    jaw_width: float = quantity(0.0, unit="mm", ge=0, description="chuck jaw width")
    jaw_height: float = quantity(0.0, unit="mm", ge=0,
                                 description="jaw height above the part's bottom face")

    @model_validator(mode="after")
    def _complete(self) -> FixtureTable:
        needs = {"mandrel": ("nut_diameter", "nut_height"),
                 "chuck": ("height", "jaw_width", "jaw_height")}[self.kind]
        for key in needs:
            if not getattr(self, key) > 0:
                raise ValueError(f"a {self.kind} needs {key} > 0 mm")
        if self.kind == "mandrel" and (self.height > 0) != (self.riser_diameter > 0):
            raise ValueError("a mandrel's riser needs both height and riser_diameter > 0")
        return self


class PairTable(Strict):
    """``[[model.pair]]``: a clearance for one pair, or a pair left out with a reason."""

    a: str = quantity(min_length=1, description="component name")
    b: str = quantity(min_length=1, description="component name")
    clearance: float | None = quantity(None, unit="mm", ge=0,
                                       description="smallest allowed distance")
    check: bool = quantity(True, description="false: the pair can never meet")
    reason: str = quantity("", description="why the pair is left out (required then)")

    @model_validator(mode="after")
    def _reason(self) -> PairTable:
        if not self.check and not self.reason.strip():
            raise ValueError("a pair left out (check = false) needs a reason")
        return self


class ModelTable(Strict):
    """``[model]``: the machine's components, its fixture and the pair rules."""

    clearance: float = quantity(2.0, unit="mm", ge=0,
                                description="default smallest distance of a checked pair")
    step: float = quantity(1.0, unit="mm", gt=0, le=10.0,
                           description="largest motion of any machine point between checks")
    component: list[ComponentTable] = quantity(default_factory=list,
                                               description="the solids")
    fixture: FixtureTable | None = quantity(None, description="what holds the blank")
    pair: list[PairTable] = quantity(default_factory=list, description="pair rules")
