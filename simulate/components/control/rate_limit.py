"""The rate-limit servo (``governor.servo_model = "rate-limit"``): a pure ramp limiter between the governor and the
guide vanes, no lag::

    y(t + dt) = y(t) + min(max(u - y(t), -dt / closing_time_s), dt / opening_time_s),
    stroke_min <= y <= stroke_max

The stroke reaches the command within a step when it can, else moves at exactly one full stroke per
``closing_time_s`` / ``opening_time_s``. It is the first-order servo's equation
(:func:`simulate.components.control.servo.lag_step`) with no lag (decay exp(-dt / T_y) = 0, T_y -> 0), so it reads
no ``servo_time_s``: the key is refused with this servo (it would be ignored).
"""

from __future__ import annotations

import numpy as np

from simulate.components.contract import LinearBlock
from simulate.components.control.servo import NO_STATE, Servo, first_order_servo_step

#: Keys of ``[governor]`` this servo reads besides the common ones (none).
GOVERNOR_KEYS: tuple[str, ...] = ()
#: It has no lag: ``governor.servo_time_s`` is not read (and refused).
LAG = False
STATES = (NO_STATE,)


def rate_limit_parameters(governor, dt_s: float) -> np.ndarray:
    """The first-order servo's vector (:data:`simulate.components.control.servo.SERVO_PARAMS`) with decay 0.

    Examples
    --------
    >>> from simulate.components.control.governor import GovernorConfig
    >>> g = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
    ...                    servo_model="rate-limit", closing_time_s=10.0, opening_time_s=20.0)
    >>> rate_limit_parameters(g, 0.01).tolist()
    [0.0, 1.0, 0.0, 0.001, 0.0005]
    """
    return np.array([governor.stroke_min, governor.stroke_max, 0.0, dt_s / governor.closing_time_s,
                     dt_s / governor.opening_time_s])


def build_rate_limit_servo(governor, initial_stroke: float, dt_s: float) -> Servo:
    """The ramp limiter of ``[governor]`` (``closing_time_s``, ``opening_time_s``, stroke limits)."""
    return Servo(first_order_servo_step, rate_limit_parameters(governor, dt_s), np.zeros(1),
                 summary={"servo_model": "rate-limit"})


def time_scales(plant, schedules) -> list:
    """None: a ramp has no time constant (its rate is exact on any step)."""
    return []


def linear_counterpart(plant, steady) -> LinearBlock:
    """y = u: a signal slower than the rate limits passes unchanged (the small signal of a linear model)."""
    return LinearBlock("y = u (within the rate limits)")


__all__ = ["STATES", "linear_counterpart", "GOVERNOR_KEYS", "LAG", "rate_limit_parameters", "build_rate_limit_servo",
           "time_scales"]
