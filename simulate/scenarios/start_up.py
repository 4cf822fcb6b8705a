"""``start-up``: the unit at standstill, guide vanes closed, breaker open; at ``event_time_s`` the governor is given
the rated speed as its reference and opens the vanes, at most to ``governor.stroke_max`` (the start-up opening
limit), the unit runs up and the governor holds it at rated speed with no load."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from simulate.scenarios.base import ScenarioConfig, Schedules, steady_schedules

#: The governor modes that control the speed (the start-up needs one).
SPEED_MODES = ("speed", "dashpot")


@dataclass(frozen=True)
class StartUp(ScenarioConfig):
    """Before ``event_time_s`` the speed reference is standstill (x_ref = -1, the governor at rest with the vanes
    closed); from it the rated speed (x_ref = 0). No load and no self-regulation throughout (the breaker stays
    open). The steady state at t = 0 is the standstill: speed 0, stroke 0, no flow, the static head at the unit;
    the characteristics must give the closed vanes (four-quadrant characteristics do, :func:`simulate.components.
    turbine.suter_kernels.closed_vane_point`)."""

    KIND: ClassVar[str] = "start-up"
    KEYS: ClassVar[tuple[str, ...]] = ("event_time_s",)
    EVENT: ClassVar[str] = "start"

    def check_plant(self, plant) -> None:
        if plant.units:
            raise InputError("scenario.kind = 'start-up' runs a plant of one unit; this plant has [[units]]: start "
                             "one unit in a plant of its own, or use another scenario kind")
        if plant.generator.model == "subtransient":
            raise InputError("scenario.kind = 'start-up' needs the swing rotor (generator.model = \"swing\"): the "
                             "sub-transient machine starts at rated speed and voltage")
        if plant.governor.stroke_min > 0.0:
            raise InputError(f"scenario.kind = 'start-up' starts with the vanes closed, below governor.stroke_min = "
                             f"{plant.governor.stroke_min!r}, which the governor would open them to at once: set "
                             f"governor.stroke_min = 0")
        if plant.governor.mode not in SPEED_MODES:
            raise InputError(f"scenario.kind = 'start-up' needs a governor that controls the speed: governor.mode "
                             f"in {list(SPEED_MODES)}, got {plant.governor.mode!r}")

    def initial_target(self) -> dict:
        return {"stroke": 0.0, "speed_rpm": 0.0}

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
        zero = np.array([0.0])
        return steady_schedules(plant, initial_stroke, initial_load_pu, initial_load=0.0,
                                initial_self_regulation=0.0, load_values=zero, self_regulation_values=zero,
                                ref_times_s=np.array([0.0, float(self.event_time_s)]),
                                ref_values=np.array([-1.0, 0.0]))
