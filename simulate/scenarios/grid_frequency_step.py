"""``grid-frequency-step``: the unit on an infinite bus (``grid.kind = "infinite-bus"``) under its governor; the bus
frequency steps by ``grid_frequency_steps`` (per unit of ``grid.frequency_hz``, cumulative) at ``step_times_s``.

The bus's frequency deviation x_bus(t) is piecewise constant; the machine's rotor angle against the bus obeys
d delta/dt = omega_b (x - x_bus) (:func:`simulate.components.electrical.generator.generator_derivatives`), so the unit
pulls into step at the bus's new speed, and the named signal ``grid_frequency_hz`` reads f_n (1 + x_bus). It is a
scenario kind, not a ``[grid]`` key, because it is an event of a run (as the island's ``load-step``): the plant file
describes the bus, the scenario what happens to it.

Refused with their reason: the swing rotor (no grid) and an island (its frequency is the unit's own: there is no bus
to step), and a unit off the bus at the start (the breaker is open at no load).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.scenarios.base import ScenarioConfig, Schedules, check_steps, steady_schedules

#: The largest bus frequency deviation, per unit: the machine's and the line's reactances are taken at rated
#: frequency, an error of the order of x_bus in the network (grids are run within a few per cent of rated).
MAX_DEVIATION = 0.1


@dataclass(frozen=True)
class GridFrequencyStep(ScenarioConfig):
    KIND: ClassVar[str] = "grid-frequency-step"
    KEYS: ClassVar[tuple[str, ...]] = ("initial_power_mw", "initial_opening", "grid_frequency_steps", "step_times_s")

    def events(self) -> list[tuple[float, str]]:
        return [(float(t), "step") for t in self.step_times_or_default]

    @property
    def steps_or_default(self) -> tuple[float, ...]:
        return tuple(self.grid_frequency_steps)

    @property
    def step_times_or_default(self) -> tuple[float, ...]:
        return tuple(self.step_times_s)

    def validate(self) -> None:
        missing = [f"scenario.{k}" for k in ("grid_frequency_steps", "step_times_s") if getattr(self, k) is None]
        if missing:
            raise InputError(f"scenario.kind = {self.KIND!r} needs {' and '.join(missing)} (the bus frequency's "
                             f"steps, per unit of grid.frequency_hz, cumulative, and their times)")
        check_steps(self, "grid_frequency_steps")
        for time_s, deviation in zip(self.step_times_s, np.cumsum(self.grid_frequency_steps)):
            if abs(deviation) > MAX_DEVIATION:
                raise InputError(f"scenario.grid_frequency_steps = {list(self.grid_frequency_steps)!r} takes the bus "
                                 f"frequency {float(deviation):+.4g} pu off rated at {float(time_s)!r} s; allowed "
                                 f"within [-{MAX_DEVIATION}, {MAX_DEVIATION}] (the machine's reactances are taken "
                                 f"at rated frequency)")
        if self.initial_power_mw is not None and self.initial_power_mw <= 0.0:
            raise InputError(f"scenario.initial_power_mw = {self.initial_power_mw!r}: scenario.kind = {self.KIND!r} "
                             f"needs the unit on the bus (a positive initial power; at no load the breaker is open "
                             f"and the bus's frequency does not reach the unit)")

    def check_plant(self, plant) -> None:
        if plant.generator.model != "subtransient":
            raise InputError(f"scenario.kind = {self.KIND!r} steps the frequency of an infinite bus: it needs "
                             f"generator.model = \"subtransient\" with grid.kind = \"infinite-bus\"; got "
                             f"generator.model = {plant.generator.model!r} (the swing rotor has no grid)")
        if plant.grid.kind != "infinite-bus":
            raise InputError(f"scenario.kind = {self.KIND!r} steps the frequency of an infinite bus; with grid.kind "
                             f"= {plant.grid.kind!r} the grid's frequency is the unit's own and there is no bus to "
                             f"step (set grid.kind = \"infinite-bus\", or disturb the island with scenario.kind = "
                             f"\"load-step\")")

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        if not initial_load_pu > 0.0:
            raise InputError(f"scenario.initial_opening = {self.initial_opening!r} gives no load "
                             f"({initial_load_pu:.4g} pu): scenario.kind = {self.KIND!r} needs the unit on the bus "
                             f"(an opening above the no-load opening)")
        return steady_schedules(plant, initial_stroke, initial_load_pu,
                                bus_frequency_times_s=np.array(self.step_times_s, dtype=float),
                                bus_frequency_values=np.cumsum(np.array(self.grid_frequency_steps, dtype=float)))
