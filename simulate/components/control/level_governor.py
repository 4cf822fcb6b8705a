"""Governor mode ``level`` (``governor.mode``): the headwater level controller of a run-of-river plant. A PI on the
error of the upstream level to its set point moves the guide vanes through the servo (``governor.servo_model``)::

    e = z - z_ref,   u = y0 + k_p e + k_i int e dt

z the upstream level (the named signal ``upstream_level_m``: the surge tank's water level, the reservoir's without
one; m above the tailwater, the datum of the heads), z_ref = ``level_setpoint_m`` (default: the level at t = 0),
k_p = ``level_kp``, k_i = ``level_ki``, y0 the initial stroke. A level above the set point opens the vanes (more
water leaves the tank than the tunnel brings), one below closes them. The PI is the governor's
(:func:`simulate.components.control.pid.pid_step`, no derivative, no droop: its integrator clamped to the stroke
limits). With k_i > 0 the level settles on the set point (at rest e = 0); with k_i = 0 a steady error remains,
e = (y - y0) / k_p. The speed is not controlled: it settles where the turbine torque meets the load (a grid's
self-regulation holds it); a scenario's speed-reference steps are refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from simulate.components.contract import ENTRIES, LinearBlock, StateArray
from simulate.components.control.pid import pid_step
from simulate.components.control.servo import build_vane_servo, first_order_servo_step
from simulate.components.control.speed_governor import CONTROLS, SERVO_STATE, refuse_speed_steps
from simulate.components.parameters import own_keys, parameter
from simulate.components.registry import Bound, CompiledPart, PartHooks
from simulate.components.signals import signal_indices


@dataclass(frozen=True)
class LevelModeConfig:
    """The level mode's own keys of ``[governor]``."""

    level_setpoint_m: float | None = parameter(None, unit="m", low=0.0, low_open=True, high=1e4,
                                               description="upstream level set point of mode level, above tailwater "
                                                           "(default: the initial level)")
    level_kp: float | None = parameter(None, unit="stroke/m", low=0.0, high=100.0,
                                       description="proportional gain of mode level")
    level_ki: float | None = parameter(None, unit="stroke/(m s)", low=0.0, high=100.0,
                                       description="integral gain of mode level")


#: Its own keys of ``[governor]`` (refused under another mode), the keys it reads and those it requires.
OWN_KEYS = own_keys(LevelModeConfig)
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)
REQUIRED_KEYS = ("level_kp", "level_ki")
#: The named signals it reads (:data:`simulate.components.signals.SIGNALS`).
READS = ("upstream_level_m",)
#: Its state: the PI's, the set point (NaN until the first step takes the level at t = 0 when no set point is
#: given), the servo's, the control vector.
STATES = (StateArray("pi", "stroke; stroke; m", "the PI's integral, its (unused) derivative and the last error",
                     ENTRIES, entries=("integral", "derivative", "previous_error")),
          StateArray("setpoint", "m", "the level set point z_ref, above tailwater", ENTRIES, entries=("level_m",)),
          SERVO_STATE, CONTROLS)
#: The servo its step calls (bound by the builder, :class:`simulate.components.registry.Bound`).
vane_servo = first_order_servo_step


@numba.njit(cache=True)
def level_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """The PI on e = z - z_ref (module docstring) at t, then the servo: controls at t_next."""
    pi, servo, reads = p
    state, setpoint, servo_state, controls = s
    level = sig[reads[0]]
    if math.isnan(setpoint[0]):  # no set point given: hold the level of t = 0
        setpoint[0] = level
    command = pid_step(pi, state, level - setpoint[0], dt_s)
    controls[0] = vane_servo(servo, servo_state, command, controls[0], dt_s)
    return controls


def level_parameters(governor, initial_stroke: float) -> np.ndarray:
    """The PI's vector in the PID's layout (:data:`simulate.components.control.pid.GOVERNOR_PARAMS`): k_p, k_i, no
    derivative, no filter, no droop, y0 and the stroke limits."""
    return np.array([governor.level_kp, governor.level_ki, 0.0, 0.0, 0.0, initial_stroke, governor.stroke_min,
                     governor.stroke_max])


def build_level_governor(plant, steady, dt_s: float, schedules):
    """The level mode's control part (refused with a scenario that steps the speed reference)."""
    refuse_speed_steps('level', 'controls the upstream level', plant, schedules)
    gov = plant.governor
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    setpoint = math.nan if gov.level_setpoint_m is None else float(gov.level_setpoint_m)
    params = (level_parameters(gov, steady.stroke), servo.params, signal_indices(READS, "governor.mode = 'level'"))
    state = (np.zeros(3), np.array([setpoint]), servo.state, np.array([steady.stroke]))
    summary = {**servo.summary, "governor_mode": "level",
               "level_setpoint_m": "the initial level" if gov.level_setpoint_m is None else setpoint}
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(level_control_step, (("vane_servo", servo.step),))},
                        params=params, state=state, hooks=PartHooks(summary=summary, reads=READS))


def time_scales(plant, schedules) -> list:
    """The PI's integral time k_p / k_i (sub-stepped within the MOC step, see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gov = plant.governor
    if gov.level_kp > 0.0 and gov.level_ki > 0.0:
        return [TimeScale("governor level integral time level_kp/level_ki", gov.level_kp / gov.level_ki)]
    return []


def linear_counterpart(plant, steady) -> LinearBlock:
    """The PI without its limits (the module docstring's equation)."""
    gov = plant.governor
    return LinearBlock("u = k_p e + k_i/s e, e = z - z_ref", {"level_kp": gov.level_kp, "level_ki": gov.level_ki},
                       {"level_kp": "stroke/m", "level_ki": "stroke/(m s)"})


__all__ = ["LevelModeConfig", "OWN_KEYS", "GOVERNOR_KEYS", "REQUIRED_KEYS", "READS", "STATES", "level_control_step",
           "level_parameters", "build_level_governor", "time_scales", "linear_counterpart"]
