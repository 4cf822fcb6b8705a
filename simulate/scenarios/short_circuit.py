"""``short-circuit``: the standard short-circuit test of the sub-transient generator (paper 001 eq. (10)): open
circuit at rated speed and at the voltage set point (``excitation.voltage_setpoint_pu``), three-phase fault at the
terminals at ``event_time_s``; speed and field voltage held. The turbine idles at no load (its torque does not reach
the held shaft)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.scenarios.base import ScenarioConfig, Schedules, steady_schedules


def require_subtransient(kind: str, plant) -> None:
    """The electrical test kinds need the sub-transient machine (the swing rotor has no field or stator)."""
    if plant.generator.model != "subtransient":
        raise InputError(f"scenario.kind = {kind!r} needs generator.model = \"subtransient\" (with [excitation] and "
                         f"[grid]); got generator.model = {plant.generator.model!r}")


@dataclass(frozen=True)
class ShortCircuit(ScenarioConfig):
    KIND: ClassVar[str] = "short-circuit"
    KEYS: ClassVar[tuple[str, ...]] = ("event_time_s",)
    EVENT: ClassVar[str] = "three-phase fault"

    def initial_target(self) -> dict:
        return {"power_mw": 0.0}

    def check_plant(self, plant) -> None:
        require_subtransient(self.KIND, plant)

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        return steady_schedules(plant, initial_stroke, initial_load_pu, initial_load=0.0, initial_self_regulation=0.0,
                                load_values=zero, self_regulation_values=zero, speed_held=True, field_held=True,
                                fault_time_s=float(self.event_time_s))
