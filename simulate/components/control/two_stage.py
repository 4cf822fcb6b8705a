"""Two-stage closing law in the servo (``governor.servo_model = "two-stage"``): the first-order servo whose closing
rate limit drops below a break stroke, as a servo with a second, throttled closing stage (the law a prescribed
``closure-law`` scenario writes as a stroke schedule, :func:`simulate.components.control.governor.closure_law`, here
acting behind the governor)::

    T_y y' = u - y,   y' >= -1 / closing_time_s                  while y > servo_break_stroke
                      y' >= -1 / servo_break_closing_time_s      once y <= servo_break_stroke

A closing step that crosses the break spends the rest of the step at the second stage's rate, so a closure at the
rate limits is the two-stage law exactly, sampled at the steps. Opening and the stroke limits are the first-order
servo's.

Parameters: the first-order servo's vector (:data:`simulate.components.control.servo.SERVO_PARAMS`), then
``[break stroke, second-stage close step]``; no state of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from simulate.components.control.servo import NO_STATE, Servo, first_order_block, first_order_parameters, lag_step, \
    require_keys
from simulate.components.control.servo import time_scales as first_order_time_scales
from simulate.components.parameters import own_keys, parameter, validate_parameters

_BREAK, _SLOW_CLOSE = 5, 6


@dataclass(frozen=True)
class TwoStageConfig:
    """The second closing stage of ``governor.servo_model = "two-stage"`` (``[governor]`` keys ``servo_break_stroke``
    and ``servo_break_closing_time_s``)."""

    break_stroke: float = parameter(unit="stroke fraction", low=0.0, low_open=True, high=1.0, high_open=True,
                                    description="stroke below which the servo closes at the second stage's rate "
                                                "(two-stage servo)")
    break_closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                            description="time of a full closing stroke at the second stage's rate "
                                                        "(two-stage servo)")

    def __post_init__(self):
        validate_parameters("servo", self)


#: Its own keys of ``[governor]``, ``servo_`` and a key of :class:`TwoStageConfig` (refused under another servo),
#: and so the keys of ``[governor]`` it reads besides the first-order servo's.
OWN_KEYS = own_keys(TwoStageConfig, prefix="servo_")
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)


def check_governor(governor) -> None:
    """Both second-stage keys are required with this servo."""
    require_keys(governor, "two-stage", GOVERNOR_KEYS, "the break stroke and the second stage's closing time")


@numba.njit(cache=True)
def two_stage_servo_step(sp, ss, command, stroke, dt_s):
    """The first-order servo (:func:`simulate.components.control.servo.lag_step`) at the closing rate of the stage
    the stroke is in; a step that crosses the break continues below it at the second stage's rate.

    Examples
    --------
    >>> sp = np.array([0.0, 1.0, 0.0, 0.1, 0.1, 0.45, 0.02])   # no lag; 0.1 a step, 0.02 below 0.45
    >>> y, out = 0.7, []
    >>> for _ in range(5):
    ...     y = float(two_stage_servo_step(sp, sp[:1], 0.0, y, 1.0))
    ...     out.append(round(y, 9))
    >>> out
    [0.6, 0.5, 0.44, 0.42, 0.4]
    """
    if stroke <= sp[_BREAK]:
        return lag_step(sp, command, stroke, sp[_SLOW_CLOSE])
    stroke_next = lag_step(sp, command, stroke, sp[3])
    if stroke_next < sp[_BREAK]:  # the break is crossed within the step: the rest of the step at the second rate
        above = (stroke - sp[_BREAK]) / (stroke - stroke_next)  # fraction of the step spent above the break
        stroke_next = max(stroke_next, sp[_BREAK] - (1.0 - above) * sp[_SLOW_CLOSE])
    return stroke_next


def build_two_stage_servo(governor, initial_stroke: float, dt_s: float) -> Servo:
    """The first-order servo of ``[governor]`` with a second closing stage below ``servo_break_stroke``."""
    params = np.append(first_order_parameters(governor, dt_s),
                       [governor.servo_break_stroke, dt_s / governor.servo_break_closing_time_s])
    return Servo(two_stage_servo_step, params, np.zeros(1),
                 summary={"servo_model": "two-stage", "servo_break_stroke": governor.servo_break_stroke})


STATES = (NO_STATE,)


def linear_counterpart(plant, steady):
    """The first-order servo's (the stages differ in the closing rate limit only, which a linear block drops)."""
    return first_order_block(plant.governor)


def time_scales(plant, schedules) -> list:
    """The first-order servo's."""
    return first_order_time_scales(plant, schedules)


__all__ = ["OWN_KEYS", "GOVERNOR_KEYS", "TwoStageConfig", "check_governor", "two_stage_servo_step",
           "build_two_stage_servo", "STATES", "linear_counterpart", "time_scales"]
