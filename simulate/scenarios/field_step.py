"""``field-step``: open circuit at rated speed and at the voltage set point (``excitation.voltage_setpoint_pu``); the
field voltage steps by ``field_step_pu`` (pu, [-1, 1], default 0.1) at ``event_time_s``, without voltage control and
with the speed held. The terminal voltage then follows the open-circuit d axis of eq. (10): two lags T'd0 and T''d0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from simulate.scenarios.base import ScenarioConfig, Schedules, steady_schedules
from simulate.scenarios.short_circuit import require_subtransient


@dataclass(frozen=True)
class FieldStep(ScenarioConfig):
    KIND: ClassVar[str] = "field-step"
    KEYS: ClassVar[tuple[str, ...]] = ("event_time_s", "field_step_pu")
    EVENT: ClassVar[str] = "field step"

    def initial_target(self) -> dict:
        return {"power_mw": 0.0}

    def check_plant(self, plant) -> None:
        require_subtransient(self.KIND, plant)

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        return steady_schedules(plant, initial_stroke, initial_load_pu, initial_load=0.0, initial_self_regulation=0.0,
                                load_values=zero, self_regulation_values=zero, speed_held=True, field_held=True,
                                field_step_time_s=float(self.event_time_s), field_step_pu=float(self.field_step_pu))
