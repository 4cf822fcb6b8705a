"""``opening-steps``: open loop: the vanes step by ``opening_steps`` (stroke fraction, cumulative) at
``step_times_s``; the load torque stays at its initial value with self-regulation e_g (paper 000 section 5)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.scenarios.base import ScenarioConfig, check_steps, PRESCRIBED, Schedules, steady_schedules


@dataclass(frozen=True)
class OpeningSteps(ScenarioConfig):
    KIND: ClassVar[str] = "opening-steps"
    KEYS: ClassVar[tuple[str, ...]] = ("initial_power_mw", "initial_opening", "opening_steps", "step_times_s")

    def events(self) -> list[tuple[float, str]]:
        return [(float(t), "step") for t in self.step_times_or_default]

    @property
    def steps_or_default(self) -> tuple[float, ...]:
        return tuple(self.opening_steps) if self.opening_steps is not None else (0.02,)

    @property
    def step_times_or_default(self) -> tuple[float, ...]:
        return tuple(self.step_times_s) if self.step_times_s is not None else (1.0,)

    def validate(self) -> None:
        check_steps(self, "opening_steps")

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        gov = plant.governor
        levels = initial_stroke + np.cumsum(self.steps_or_default)
        bad = (levels < gov.stroke_min) | (levels > gov.stroke_max)
        if np.any(bad):
            raise InputError(f"scenario.opening_steps take the stroke to {levels[bad][0]:.6g}, outside "
                             f"[governor.stroke_min, governor.stroke_max] = [{gov.stroke_min}, {gov.stroke_max}] "
                             f"(initial stroke {initial_stroke:.6g})")
        times = np.array(self.step_times_or_default)
        law_t = np.concatenate(([0.0], np.repeat(times, 2)))
        law_y = np.concatenate(([initial_stroke], np.ravel(np.column_stack((
            np.concatenate(([initial_stroke], levels[:-1])), levels)))))
        return steady_schedules(plant, initial_stroke, initial_load_pu, mode=PRESCRIBED, law_times_s=law_t,
                                law_strokes=law_y)
