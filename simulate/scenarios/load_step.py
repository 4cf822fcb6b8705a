"""``load-step``: grid-connected with load self-regulation e_g; the load torque steps by ``load_step`` times the
initial load at ``event_time_s`` (paper 001 eq. (14))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.scenarios.base import ScenarioConfig, Schedules, steady_schedules


@dataclass(frozen=True)
class LoadStep(ScenarioConfig):
    KIND: ClassVar[str] = "load-step"
    KEYS: ClassVar[tuple[str, ...]] = ("initial_power_mw", "initial_opening", "event_time_s", "load_step")

    def events(self) -> list[tuple[float, str]]:
        return [(float(self.event_time_s), f"load step {self.load_step:+g}")]

    def check_plant(self, plant) -> None:
        grid = getattr(plant, "grid", None)
        if grid is not None and grid.kind == "infinite-bus":
            raise InputError("scenario.kind = 'load-step' steps the island load; with grid.kind = 'infinite-bus' the "
                             "bus takes any power and there is no load to step (use grid.kind = 'island')")

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        return steady_schedules(plant, initial_stroke, initial_load_pu, load_times_s=np.array([self.event_time_s]),
                                load_values=np.array([initial_load_pu * (1.0 + self.load_step)]))
