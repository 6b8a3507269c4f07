"""A feed-drive model for every axis of a machine: identified or a stated default.

A servo prediction from a partly modelled machine is wrong in a systematic way: an
axis that "follows its command" turns the ordinary following lag of the others
(feed x delay, about a millimetre at finishing feeds) into a contour error. On a real
machine every axis lags and the builder matches the gains, so that what remains is
the *mismatch*. This module therefore gives every axis of the machine file a model:

* **identified**: the axis's own ``[axes.N.servo]`` table (all keys of
  ``cam.motion.schema.FeedDriveServo``);
* **default** (no servo table): a copy of the *template*, the identified
  axis of the same kind (linear / rotary; any identified axis when none of that kind
  is) whose ramp lag ``alpha_th / omega = Ts / 2 + (1 - K_FFP/100) / Kpp`` is largest,
  i.e. the axis the builder matches the others to (equal lags, to 1 ns: the one at
  the larger K_FFP, whose lag is its smoothing's, not its position loop's). The loop
  (Kpp, Kvp, Kvi, Ts, Ta, Tp, K_FFP), the mechanism (J, C, screw lead) are copied;
  the default axis has no load inertia and its torque limit is the machine file's
  acceleration limit of the axis at that inertia: ``torque = (J + J1) a_max`` in motor
  units (the drive can just give the acceleration the machine file promises). Without
  any identified axis a default is refused: there is nothing to match to, and a
  made-up drive would be reported as if it were the machine's.

Which axes are defaulted, and to which template, is part of every servo result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from cam.motion.feeddrive import FeedDriveAxis, alpha_th, axis_from_servo
from cam.motion.schema import FeedDriveServo
from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from postproc.machine import AxisSpec, Machine

__all__ = ["AxisModels", "default_axis", "machine_axis_models"]

#: Keys a servo table must give for the axis to count as identified.
REQUIRED_KEYS: frozenset[str] = frozenset(
    name for name, f in FeedDriveServo.model_fields.items() if f.is_required())


@dataclass(frozen=True)
class AxisModels:
    """Feed-drive models of all axes of a machine.

    Attributes
    ----------
    models : dict of int -> FeedDriveAxis
        By joint column (the machine's axis order), every axis.
    source : dict of str -> str
        Per axis name: ``"identified"`` or ``"default: matched to <template>"``.
    """

    models: dict[int, FeedDriveAxis]
    source: dict[str, str]

    @property
    def default_axes(self) -> list[str]:
        """Names of the axes modelled by the default."""
        return [name for name, text in self.source.items() if text != "identified"]

    def by_name(self) -> dict[str, FeedDriveAxis]:
        """Models keyed by axis name.

        Returns
        -------
        dict of str to FeedDriveAxis
            ``{"X": model, ...}``.
        """
        return {model.name: model for model in self.models.values()}


def _ramp_lag(axis: FeedDriveAxis) -> tuple[float, float]:
    """Ramp lag (s, rounded to 1 ns so matched axes tie), then K_FFP."""
    return round(float(alpha_th(axis, 1.0)), 9), axis.k_ffp


def default_axis(spec: AxisSpec, template: FeedDriveAxis) -> FeedDriveAxis:
    """The stated default model of ``spec``: ``template``'s drive, ``spec``'s limit.

    Parameters
    ----------
    spec : AxisSpec
        The axis (its acceleration limit in mm/s^2 or rad/s^2 sets the torque limit).
    template : FeedDriveAxis
        The identified axis whose loop and mechanism are copied.

    Returns
    -------
    FeedDriveAxis
        Named ``spec.name``, no load inertia, torque limit
        ``J a_max * motor_per_unit`` N m.
    """
    axis = replace(template, name=spec.name, rotary=spec.rotary, load_inertia=0.0)
    if not spec.rotary and template.rotary:
        axis = replace(axis, screw_lead=None)
    acceleration = spec.acceleration * axis.motor_per_unit  # motor rad/s^2
    limit = axis.total_inertia * acceleration if acceleration > 0.0 else math.inf
    return replace(axis, torque_limit=limit)


def machine_axis_models(machine: Machine) -> AxisModels:
    """A feed-drive model for every axis of ``machine`` (module doc for the rule).

    Parameters
    ----------
    machine : Machine
        The machine file: each axis's ``[axes.<NAME>.servo]`` table, limits.

    Returns
    -------
    AxisModels
        One model per joint column, identified or defaulted (``source`` says which).

    Raises
    ------
    InputError
        A servo table with out-of-range values, or no axis with a complete servo
        table (nothing to match the others to).
    """
    specs = list(machine.axes.values())
    identified: dict[int, FeedDriveAxis] = {}
    for column, spec in enumerate(specs):
        if spec.servo:  # an incomplete table is an error (validation names the key)
            identified[column] = axis_from_servo(spec.name, dict(spec.servo), spec.rotary,
                                                 machine.source)
    if not identified:
        raise InputError("no axis has servo data: the feed-drive model needs at least one "
                         "identified axis to match the others to", file=machine.source,
                         field="axes.<NAME>.servo",
                         accepted="an [axes.<NAME>.servo] table with "
                         + ", ".join(sorted(REQUIRED_KEYS)))
    models: dict[int, FeedDriveAxis] = {}
    source: dict[str, str] = {}
    for column, spec in enumerate(specs):
        if column in identified:
            models[column] = identified[column]
            source[spec.name] = "identified"
            continue
        same = [a for a in identified.values() if a.rotary == spec.rotary]
        template = max(same or list(identified.values()), key=_ramp_lag)
        models[column] = default_axis(spec, template)
        source[spec.name] = f"default: matched to {template.name}"
    return AxisModels(models=models, source=source)
