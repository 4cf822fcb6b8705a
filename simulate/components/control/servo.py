"""The servo between a governor and the guide vanes (registry kind "servo", key ``governor.servo_model``), and the
first-order servo every other one builds on.

A servo component offers one compiled function ``step(sp, ss, command, stroke, dt_s) -> stroke``: the guide-vane
stroke at the end of a step of ``dt_s`` s, from the governor's stroke command and the stroke at its start (fractions
of the full stroke), with its parameter vector ``sp`` and its state vector ``ss`` (updated in place). Its builder
``build(governor, initial_stroke, dt_s) -> Servo`` takes the ``[governor]`` section; the keys a servo reads beyond the
first-order ones are its own, declared in its module (``OWN_KEYS``, :func:`simulate.components.parameters.own_keys`:
registering the servo brings them into ``[governor]``, which refuses them under another ``servo_model``), and its
time scales its module's ``time_scales(plant, schedules)``. The governor's control step calls the servo its builder
bound (:class:`simulate.components.registry.Bound`), so a new servo is one module and one line in
:data:`simulate.components.registry.SERVOS`.

First-order servo ("first-order", the default)::

    T_y y' = u - y,   |y'| <= 1 / closing_time_s (closing), 1 / opening_time_s (opening),
    stroke_min <= y <= stroke_max
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numba
import numpy as np

from simulate.components.contract import SCALAR, LinearBlock, StateArray
from simulate.components.registry import SERVOS

#: Layout of the first-order servo's parameter vector (``decay`` = exp(-dt / T_y); ``close_step``/``open_step``:
#: the largest stroke change per step, dt / closing_time_s and dt / opening_time_s).
SERVO_PARAMS = ("stroke_min", "stroke_max", "decay", "close_step", "open_step")
#: Keys of ``[governor]`` this servo reads besides the common ones (none: it is the common one).
GOVERNOR_KEYS: tuple[str, ...] = ()
#: A servo without a state of its own (the stroke it moves is the control vector's): one unused value.
NO_STATE = StateArray("unused", "", "none: the servo keeps no state of its own (one unused value)", SCALAR)
STATES = (NO_STATE,)


def require_keys(governor, model: str, keys, what: str) -> None:
    """:class:`InputError` naming the ``[governor]`` keys among ``keys`` that ``governor.servo_model = model`` needs
    and the section leaves out (``what`` says what they are)."""
    from hillchart.errors import InputError

    missing = [f"governor.{k}" for k in keys if getattr(governor, k) is None]
    if missing:
        raise InputError(f"governor.servo_model = \"{model}\" needs {' and '.join(missing)} ({what})")


@dataclass(frozen=True)
class Servo:
    """A compiled servo: its ``step`` function (module docstring), parameter and state vectors, and the figures it
    adds to the run's summary."""

    step: Callable
    params: np.ndarray
    state: np.ndarray
    summary: dict = field(default_factory=dict)


def first_order_parameters(governor, dt_s: float) -> np.ndarray:
    """The float vector (layout :data:`SERVO_PARAMS`) of the ``[governor]`` section's servo keys at step ``dt_s``.

    Examples
    --------
    >>> from simulate.components.control.governor import GovernorConfig
    >>> g = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
    ...                    servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    >>> [round(float(v), 4) for v in first_order_parameters(g, 0.01)]
    [0.0, 1.0, 0.9512, 0.001, 0.0005]
    """
    return np.array([governor.stroke_min, governor.stroke_max, math.exp(-dt_s / governor.servo_time_s),
                     dt_s / governor.closing_time_s, dt_s / governor.opening_time_s])


@numba.njit(cache=True)
def servo_step(params, command, stroke):
    """First-order servo T_y y' = u - y (exact for a constant command over the step), rate limited to one full
    stroke per closing/opening time, clipped to the stroke limits (``params``: layout :data:`SERVO_PARAMS`).

    Examples
    --------
    >>> p = np.array([0.0, 1.0, 0.9, 0.01, 0.005])
    >>> round(float(servo_step(p, 0.0, 0.5)), 4), round(float(servo_step(p, 0.52, 0.5)), 4)
    (0.49, 0.502)
    """
    return lag_step(params, command, stroke, params[3])


@numba.njit(cache=True)
def lag_step(params, command, stroke, close_step):
    """:func:`servo_step` with the closing rate limit ``close_step`` (stroke per step) given: the one
    implementation of the first-order servo's equation (a servo whose closing rate changes along the stroke calls it
    with the rate of the moment)."""
    y_min, y_max, decay, open_step = params[0], params[1], params[2], params[4]
    change = (command - stroke) * (1.0 - decay)
    if change < -close_step:
        change = -close_step
    elif change > open_step:
        change = open_step
    return min(max(stroke + change, y_min), y_max)


@numba.njit(cache=True)
def first_order_servo_step(sp, ss, command, stroke, dt_s):
    """The servo component's step (:func:`servo_step`; no state of its own)."""
    return servo_step(sp, command, stroke)


def build_first_order(governor, initial_stroke: float, dt_s: float) -> Servo:
    """The first-order servo of ``[governor]`` (``servo_time_s``, ``closing_time_s``, ``opening_time_s``, stroke
    limits)."""
    return Servo(first_order_servo_step, first_order_parameters(governor, dt_s), np.zeros(1))


def build_vane_servo(plant, initial_stroke: float, dt_s: float) -> Servo:
    """The plant's guide-vane servo (``governor.servo_model``, :data:`simulate.components.registry.SERVOS`)."""
    return SERVOS.builder(plant.governor.servo_model)(plant.governor, initial_stroke, dt_s)


def time_scales(plant, schedules) -> list:
    """T_y, sub-stepped within the MOC step (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    return [TimeScale("governor.servo_time_s", plant.governor.servo_time_s)]


def linear_counterpart(plant, steady) -> LinearBlock:
    """T_y y' = u - y without its rate and stroke limits (the module docstring's equation)."""
    return first_order_block(plant.governor)


def first_order_block(governor) -> LinearBlock:
    """The first-order servo's :class:`LinearBlock` (T_y of the ``[governor]`` section)."""
    return LinearBlock("T_y y' = u - y (the first-order servo without its limits)",
                       {"servo_time_s": governor.servo_time_s}, {"servo_time_s": "s"})


__all__ = ["SERVO_PARAMS", "GOVERNOR_KEYS", "NO_STATE", "STATES", "linear_counterpart", "first_order_block",
           "require_keys", "Servo", "first_order_parameters", "servo_step", "lag_step",
           "first_order_servo_step", "build_first_order", "build_vane_servo", "time_scales"]
