"""``closure-law``: load rejection at ``event_time_s`` with no governor: the vanes follow a prescribed linear or
two-stage closure (the regulating-guarantee calculation)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.components.control.governor import closure_law
from simulate.scenarios.base import ScenarioConfig, PRESCRIBED, Schedules, steady_schedules


@dataclass(frozen=True)
class ClosureLaw(ScenarioConfig):
    KIND: ClassVar[str] = "closure-law"
    KEYS: ClassVar[tuple[str, ...]] = ("initial_power_mw", "initial_opening", "event_time_s", "closing_time_s",
                                       "break_opening", "break_time_s")
    EVENT: ClassVar[str] = "load rejection"

    def validate(self) -> None:
        if self.closing_time_s is None:
            raise InputError("scenario.closing_time_s is required for kind 'closure-law' (s, >= 0; "
                             "0 closes in one step)")
        if (self.break_opening is None) != (self.break_time_s is None):
            raise InputError("scenario.break_opening and scenario.break_time_s go together; got "
                             f"{self.break_opening!r} and {self.break_time_s!r}")

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        law_t, law_y = closure_law(initial_stroke, self.event_time_s, self.closing_time_s, self.break_opening,
                                   self.break_time_s)
        return steady_schedules(plant, initial_stroke, initial_load_pu, mode=PRESCRIBED, law_times_s=law_t,
                                law_strokes=law_y, load_times_s=np.array([self.event_time_s]), load_values=zero,
                                self_regulation_values=zero)
