"""Dead time in front of the first-order servo (``governor.servo_model = "dead-time"``): the servo receives the
governor's command ``servo_dead_time_s`` late (the transport delay of the signal path and the pilot valve)::

    T_y y'(t) = u(t - T_d) - y(t),   with the rate and stroke limits of the first-order servo

The delay is a ring buffer of the last n = T_d / dt commands (T_d a whole multiple of the control step dt; before
the run the command was the steady one, the initial stroke). The servo equation is the first-order servo's
(:func:`simulate.components.control.servo.servo_step`) on the delayed command, so the response to any command
sequence is the delay-free one shifted by n steps, exactly.

State layout: ``[next slot, u(k - n), ..., u(k - 1)]`` (the slot as a float).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import DELAY_LINE, LinearBlock, StateArray
from simulate.components.control.servo import Servo, first_order_parameters, require_keys, servo_step
from simulate.components.control.servo import time_scales as first_order_time_scales
from simulate.components.parameters import own_keys, parameter, validate_parameters


@dataclass(frozen=True)
class DeadTimeConfig:
    """The dead time of ``governor.servo_model = "dead-time"`` (``[governor]`` key ``servo_dead_time_s``)."""

    dead_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=10.0,
                                   description="dead time T_d of the command before the servo (dead-time servo; a "
                                               "whole multiple of the control step)")

    def __post_init__(self):
        validate_parameters("servo", self)


#: Its own keys of ``[governor]``, ``servo_`` and a key of :class:`DeadTimeConfig` (refused under another servo),
#: and so the keys of ``[governor]`` it reads besides the first-order servo's.
OWN_KEYS = own_keys(DeadTimeConfig, prefix="servo_")
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)


def check_governor(governor) -> None:
    """``servo_dead_time_s`` is required with this servo."""
    require_keys(governor, "dead-time", GOVERNOR_KEYS, "s, the dead time of the command before the servo")


def delay_steps(dead_time_s: float, dt_s: float) -> int:
    """n = T_d / dt, or :class:`InputError` naming the key unless ``dt_s`` divides the dead time.

    >>> delay_steps(0.3, 0.02)
    15
    """
    ratio = dead_time_s / dt_s
    if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
        raise InputError(f"governor.servo_dead_time_s = {dead_time_s!r} must be a whole multiple of the control step "
                         f"{dt_s!r} s (the delay holds one command per step); set governor.servo_dead_time_s, "
                         f"solver.dt_s (or penstock.reaches) or solver.substeps")
    return int(round(ratio))


@numba.njit(cache=True)
def dead_time_servo_step(sp, ss, command, stroke, dt_s):
    """The first-order servo on the command of n steps ago (``sp``: the first-order servo's vector; ``ss``: the
    ring buffer, module docstring); stores this step's command.

    Examples
    --------
    >>> sp = np.array([0.0, 1.0, 0.0, 1.0, 1.0]); ss = np.array([0.0, 0.5, 0.5])   # n = 2, no lag, no rate limit
    >>> [float(dead_time_servo_step(sp, ss, 0.8, 0.5, 0.1)) for _ in range(3)]
    [0.5, 0.5, 0.8]
    """
    n = ss.size - 1
    slot = int(ss[0])
    delayed = ss[1 + slot]
    ss[1 + slot] = command
    ss[0] = float((slot + 1) % n)
    return servo_step(sp, delayed, stroke)


def build_dead_time_servo(governor, initial_stroke: float, dt_s: float) -> Servo:
    """The first-order servo of ``[governor]`` behind a dead time of ``servo_dead_time_s``."""
    n = delay_steps(governor.servo_dead_time_s, dt_s)
    state = np.full(n + 1, float(initial_stroke))
    state[0] = 0.0
    return Servo(dead_time_servo_step, first_order_parameters(governor, dt_s), state,
                 summary={"servo_model": "dead-time", "servo_dead_time_steps": n})


#: Its state: the ring buffer of the module docstring.
STATES = (StateArray("delay", "slot; stroke fraction", "the next slot, then the commands of the last n steps",
                     DELAY_LINE, entries=("slot",)),)


def linear_counterpart(plant, steady) -> LinearBlock:
    """exp(-T_d s) / (1 + T_y s): the first-order servo behind the dead time, without the limits."""
    gov = plant.governor
    return LinearBlock("T_y y'(t) = u(t - T_d) - y(t)", {"servo_time_s": gov.servo_time_s,
                                                        "servo_dead_time_s": gov.servo_dead_time_s},
                       {"servo_time_s": "s", "servo_dead_time_s": "s"})


def time_scales(plant, schedules) -> list:
    """The first-order servo's (the dead time is held exactly by the buffer, whatever the step)."""
    return first_order_time_scales(plant, schedules)


__all__ = ["OWN_KEYS", "GOVERNOR_KEYS", "DeadTimeConfig", "check_governor", "delay_steps", "dead_time_servo_step",
           "build_dead_time_servo", "STATES", "linear_counterpart", "time_scales"]
