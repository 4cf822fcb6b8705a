"""``frequency-steps``: no load (breaker open), speed reference steps ``speed_steps`` (cumulative, per unit) at
``step_times_s`` (paper 004 Fig. 11a: +4 %, -8 %, +4 % at 10, 40, 70 s)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from simulate.scenarios.base import ScenarioConfig, check_steps, Schedules, steady_schedules


@dataclass(frozen=True)
class FrequencySteps(ScenarioConfig):
    KIND: ClassVar[str] = "frequency-steps"
    KEYS: ClassVar[tuple[str, ...]] = ("speed_steps", "step_times_s")

    def events(self) -> list[tuple[float, str]]:
        return [(float(t), "step") for t in self.step_times_or_default]

    @property
    def steps_or_default(self) -> tuple[float, ...]:
        return tuple(self.speed_steps) if self.speed_steps is not None else (0.04, -0.08, 0.04)

    @property
    def step_times_or_default(self) -> tuple[float, ...]:
        return tuple(self.step_times_s) if self.step_times_s is not None else (10.0, 40.0, 70.0)

    def validate(self) -> None:
        check_steps(self, "speed_steps")

    def initial_target(self) -> dict:
        return {"power_mw": 0.0}

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        return steady_schedules(plant, initial_stroke, initial_load_pu, initial_load=0.0,
                                initial_self_regulation=0.0, load_values=zero, self_regulation_values=zero,
                                ref_times_s=np.array(self.step_times_or_default),
                                ref_values=np.cumsum(self.steps_or_default))
