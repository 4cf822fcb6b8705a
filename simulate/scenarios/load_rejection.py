"""``load-rejection``: governor in control; the breaker opens at ``event_time_s``: generator torque and load
self-regulation drop to zero (paper 004 Fig. 11b)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from simulate.scenarios.base import ScenarioConfig, Schedules, steady_schedules


@dataclass(frozen=True)
class LoadRejection(ScenarioConfig):
    KIND: ClassVar[str] = "load-rejection"
    KEYS: ClassVar[tuple[str, ...]] = ("initial_power_mw", "initial_opening", "event_time_s")
    EVENT: ClassVar[str] = "load rejection"

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        return steady_schedules(plant, initial_stroke, initial_load_pu, load_times_s=np.array([self.event_time_s]),
                                load_values=zero, self_regulation_values=zero)
