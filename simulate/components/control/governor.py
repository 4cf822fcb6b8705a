"""Speed governor (parallel PID with permanent droop and derivative filter), hydraulic servo, and prescribed
guide-vane laws. Pure step functions on per-unit quantities (paper 000 sections 2.5-2.7).

Signals: x = n / n_r - 1 (per-unit speed deviation), x_ref the per-unit speed reference, y the servo stroke
(fraction of full stroke; chart opening a = y * opening_max).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.control.discrete_servo import (DiscreteServoConfig, check_servo_step,
                                                       discrete_servo_parameters, discrete_servo_step,
                                                       initial_servo_state)
from simulate.components.parameters import borrowed, parameter, validate_parameters
from simulate.components.schedules import GOVERNOR, piecewise_constant, piecewise_linear

@dataclass(frozen=True)
class GovernorConfig:
    """Parallel PID on the per-unit speed error with permanent droop, derivative filter and a first-order servo.

    ``kp`` (stroke per unit speed), ``ki`` (1/s), ``kd`` (s); ``derivative_filter_s`` T_f of kd s / (1 + T_f s);
    ``permanent_droop`` b_p (per-unit speed per stroke); ``servo_time_s`` T_y; ``closing_time_s`` and
    ``opening_time_s``: time for a full stroke at the rate limit; ``stroke_min``/``stroke_max`` stroke limits.

    ``servo_model``: ``"first-order"`` (default: T_y, rate limits, stroke limits) or ``"discrete"``: paper 000's
    second-order sampled servo, eq. (37), u(k) = a1 u(k-1) + a2 u(k-2) + b0 u_s(k) every ``servo_sample_time_s``
    (held in between; a whole multiple of the time step), keys ``servo_b0``, ``servo_a1``, ``servo_a2``,
    ``servo_sample_time_s`` (defaults: the printed 0.5 / (1 - z^-1 + 0.5 z^-2) at 0.2 s; DC gain 1 and stable poles
    required), with the stroke limits and the rate limits ``closing_time_s``/``opening_time_s`` applied at each sample
    (``servo_time_s`` then acts only through the time-step guards).
    """

    kp: float = parameter(unit="stroke/pu speed", low=0.0, high=1000.0, description="proportional gain")
    ki: float = parameter(unit="stroke/(pu speed s)", low=0.0, high=1000.0, description="integral gain")
    kd: float = parameter(unit="stroke s/pu speed", low=0.0, high=1000.0, description="derivative gain")
    derivative_filter_s: float = parameter(unit="s", low=0.0, high=100.0,
                                           description="time constant T_f of the derivative filter")
    permanent_droop: float = parameter(unit="pu speed/stroke", low=0.0, high=1.0, high_open=True,
                                       description="permanent droop b_p, on the servo stroke")
    servo_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                    description="time constant T_y of the first-order servo")
    closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full closing stroke at the rate limit")
    opening_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full opening stroke at the rate limit")
    stroke_min: float = parameter(0.0, unit="stroke fraction", low=0.0, high=1.0, description="lower stroke limit")
    stroke_max: float = parameter(1.0, unit="stroke fraction", low=0.0, low_open=True, high=1.5,
                                  description="upper stroke limit")
    servo_model: str = parameter("first-order", unit="", choices=("first-order", "discrete"),
                                 description="the servo between the governor and the guide vanes")
    servo_b0: float | None = borrowed(DiscreteServoConfig, "b0")
    servo_a1: float | None = borrowed(DiscreteServoConfig, "a1")
    servo_a2: float | None = borrowed(DiscreteServoConfig, "a2")
    servo_sample_time_s: float | None = borrowed(DiscreteServoConfig, "sample_time_s")

    DISCRETE_KEYS: ClassVar[tuple[str, ...]] = ("servo_b0", "servo_a1", "servo_a2", "servo_sample_time_s")

    def __post_init__(self):
        validate_parameters("governor", self)
        if self.stroke_min >= self.stroke_max:
            raise InputError(f"governor.stroke_min must be < governor.stroke_max = {self.stroke_max!r}, "
                             f"got {self.stroke_min!r}")
        given = [k for k in self.DISCRETE_KEYS if getattr(self, k) is not None]
        if self.servo_model != "discrete" and given:
            raise InputError(f"governor.{given[0]} is a key of governor.servo_model = \"discrete\" (eq. (37)); got "
                             f"servo_model = {self.servo_model!r}")
        if self.servo_model == "discrete":
            self.discrete_servo  # validates eq. (37)'s coefficients

    @property
    def discrete_servo(self) -> DiscreteServoConfig:
        """:class:`simulate.components.control.discrete_servo.DiscreteServoConfig` of the ``servo_*`` keys
        (servo_model "discrete")."""
        keys = {k[len("servo_"):]: getattr(self, k) for k in self.DISCRETE_KEYS if getattr(self, k) is not None}
        try:
            return DiscreteServoConfig(**keys, stroke_min=self.stroke_min, stroke_max=self.stroke_max,
                                       closing_time_s=self.closing_time_s, opening_time_s=self.opening_time_s)
        except InputError as exc:
            raise InputError("governor (servo_model = \"discrete\", eq. (37)): "
                             + str(exc).replace("servo.", "governor.servo_").replace("servo: ", "")) from None


#: Layout of the governor parameter vector passed to the compiled loop.
GOVERNOR_PARAMS = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop", "initial_stroke", "stroke_min",
                   "stroke_max", "servo_decay", "close_step", "open_step")


def governor_parameters(governor, initial_stroke: float, dt_s: float) -> np.ndarray:
    """The float vector (layout :data:`GOVERNOR_PARAMS`) for :func:`governor_step` and :func:`servo_step`.

    ``servo_decay`` = exp(-dt / T_y); ``close_step`` / ``open_step`` = the largest stroke change per step,
    dt / closing_time_s and dt / opening_time_s.

    Examples
    --------
    >>> g = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
    ...                    servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    >>> [round(float(v), 4) for v in governor_parameters(g, 0.8, 0.01)[-3:]]
    [0.9512, 0.001, 0.0005]
    """
    return np.array([governor.kp, governor.ki, governor.kd, governor.derivative_filter_s, governor.permanent_droop,
                     initial_stroke, governor.stroke_min, governor.stroke_max, math.exp(-dt_s / governor.servo_time_s),
                     dt_s / governor.closing_time_s, dt_s / governor.opening_time_s])


@numba.njit(cache=True)
def governor_step(params, state, speed_dev, speed_ref, stroke, dt_s):
    """Controller output u (stroke command) after one step; updates ``state`` = [integral, derivative, e_prev].

    e = x_ref - x - b_p (y - y0) (permanent droop on the servo stroke);
    u = y0 + kp e + I + D, I' = ki e, T_f D' + D = kd e' (backward Euler). The command is clipped to the stroke
    limits. Anti-windup by integrator clamping: the integral stays within [stroke_min - y0, stroke_max - y0], so
    it can always bring the command back from either limit. (Back-calculation of the clipped amount would load the
    derivative kick of a reference step into the integral, which then drives the vanes the wrong way as the kick
    decays; conditional integration would freeze the integral during a long overspeed, and the proportional part
    alone would reopen the vanes while the unit is still far above speed.)

    Examples
    --------
    >>> p = np.array([2.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.9, 0.01, 0.01])
    >>> s = np.zeros(3)
    >>> round(float(governor_step(p, s, -0.01, 0.0, 0.5, 0.1)), 4)   # 0.5 + 2*0.01 + 0.5*0.01*0.1
    0.5205
    """
    kp, ki, kd, tf = params[0], params[1], params[2], params[3]
    droop, y0, y_min, y_max = params[4], params[5], params[6], params[7]
    error = speed_ref - speed_dev - droop * (stroke - y0)
    state[1] = (tf * state[1] + kd * (error - state[2])) / (tf + dt_s)
    state[2] = error
    state[0] = min(max(state[0] + ki * error * dt_s, y_min - y0), y_max - y0)
    command = y0 + kp * error + state[0] + state[1]
    return min(max(command, y_min), y_max)


@numba.njit(cache=True)
def servo_step(params, command, stroke):
    """First-order servo T_y y' = u - y (exact for a constant command over the step), rate limited to one full
    stroke per closing/opening time, clipped to the stroke limits.

    Examples
    --------
    >>> p = np.array([0, 0, 0, 0, 0, 0.5, 0.0, 1.0, 0.9, 0.01, 0.005])
    >>> round(float(servo_step(p, 0.0, 0.5)), 4), round(float(servo_step(p, 0.52, 0.5)), 4)
    (0.49, 0.502)
    """
    y_min, y_max, decay, close_step, open_step = params[6], params[7], params[8], params[9], params[10]
    change = (command - stroke) * (1.0 - decay)
    if change < -close_step:
        change = -close_step
    elif change > open_step:
        change = open_step
    return min(max(stroke + change, y_min), y_max)


def closure_law(initial_stroke: float, start_s: float, closing_time_s: float, break_opening: float | None = None,
                break_time_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints (times s, strokes) of a linear or two-stage closure from ``initial_stroke`` to 0.

    First stage at the rate of a full stroke per ``closing_time_s`` (0: closes within one step); below
    ``break_opening`` the rate of a full stroke per ``break_time_s``.

    Examples
    --------
    >>> t, y = closure_law(0.8, 1.0, 10.0)
    >>> t.tolist(), y.tolist()
    ([1.0, 9.0], [0.8, 0.0])
    >>> t, y = closure_law(0.8, 1.0, 10.0, break_opening=0.2, break_time_s=20.0)
    >>> [round(float(v), 6) for v in t], y.tolist()
    ([1.0, 7.0, 11.0], [0.8, 0.2, 0.0])
    """
    times, strokes = [start_s], [initial_stroke]
    level, now = initial_stroke, start_s
    if break_opening is not None and break_opening < initial_stroke:
        now += (level - break_opening) * closing_time_s
        times.append(now)
        strokes.append(break_opening)
        level = break_opening
        now += level * break_time_s
    else:
        now += level * closing_time_s
    times.append(now)
    strokes.append(0.0)
    return np.array(times), np.array(strokes)


# ---------------------------------------------------------------------------------------------------------------
# Components for the time loop (registry kind "control"; see simulate.components.registry)
# ---------------------------------------------------------------------------------------------------------------
# A control component owns the control vector (fractions of each control's full stroke; control 0 the guide vane)
# and offers  step(p, s, speed_rpm, t_s, t_next_s, dt_s) -> controls  (the vector at t_next, an array of its state).
@numba.njit(cache=True)
def governor_control_step(p, s, speed_rpm, t_s, t_next_s, dt_s):
    """Governor PID on the speed at t, then the guide-vane servo: controls at t_next."""
    gov, ref_times, ref_values, scal = p
    state, controls = s
    x = speed_rpm / scal[0] - 1.0
    x_ref = piecewise_constant(ref_times, ref_values, t_s + scal[1], 0.0)
    command = governor_step(gov, state, x, x_ref, controls[0], dt_s)
    controls[0] = servo_step(gov, command, controls[0])
    return controls


@numba.njit(cache=True)
def prescribed_control_step(p, s, speed_rpm, t_s, t_next_s, dt_s):
    """The prescribed stroke law at t_next (piecewise linear)."""
    law_times, law_strokes, scal = p
    controls = s[0]
    controls[0] = piecewise_linear(law_times, law_strokes, t_next_s + scal[0])
    return controls


def build_governor(plant, steady, dt_s: float, schedules):
    """Governor + servo on the guide vane; the speed reference follows the scenario's schedule. The servo is the
    first-order one, or paper 000's discrete eq. (37) with ``governor.servo_model = "discrete"``."""
    from simulate.components.registry import CompiledPart

    if plant.governor.servo_model == "discrete":
        return build_discrete_governor(plant, steady, dt_s, schedules)

    scal = np.array([plant.turbine.rated_speed_rpm, 1e-9 * dt_s])
    params = (governor_parameters(plant.governor, steady.stroke, dt_s), schedules.ref_times_s, schedules.ref_values,
              scal)
    return CompiledPart(kind="control", name="governor", functions={"step": governor_control_step},
                        params=params, state=(np.zeros(3), np.array([steady.stroke])), signals=())


def build_prescribed(plant, steady, dt_s: float, schedules):
    """The guide vane follows the scenario's prescribed law (no governor)."""
    from simulate.components.registry import CompiledPart

    params = (schedules.law_times_s, schedules.law_strokes, np.array([1e-9 * dt_s]))
    return CompiledPart(kind="control", name="prescribed", functions={"step": prescribed_control_step},
                        params=params, state=(np.array([steady.stroke]),))


# ---------------------------------------------------------------------------------------------------------------
# Component for the time loop (registry kind "control", chosen by governor.servo_model = "discrete")
# ---------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def governor_discrete_servo_step(p, s, speed_rpm, t_s, t_next_s, dt_s):
    """Governor PID on the speed at t (:func:`governor_step`), then the eq. (37) servo: the
    controls at t_next."""
    gov, ref_times, ref_values, scal, servo = p
    state, controls, servo_state = s
    x = speed_rpm / scal[0] - 1.0
    x_ref = piecewise_constant(ref_times, ref_values, t_s + scal[1], 0.0)
    command = governor_step(gov, state, x, x_ref, controls[0], dt_s)
    controls[0] = discrete_servo_step(servo, servo_state, command, dt_s)
    return controls


def build_discrete_governor(plant, steady, dt_s: float, schedules):
    """The governor of :func:`build_governor` with paper 000's discrete servo (eq. (37)) in place
    of the first-order one; ``dt_s`` must divide ``governor.servo_sample_time_s``."""
    from simulate.components.registry import CompiledPart, PartHooks

    config = plant.governor.discrete_servo
    try:
        check_servo_step(config, dt_s)
    except InputError as exc:
        raise InputError(str(exc).replace("servo.sample_time_s", "governor.servo_sample_time_s")
                         + "; set solver.dt_s (or penstock.reaches) or governor.servo_sample_time_s") from None
    scal = np.array([plant.turbine.rated_speed_rpm, 1e-9 * dt_s])
    params = (governor_parameters(plant.governor, steady.stroke, dt_s), schedules.ref_times_s, schedules.ref_values,
              scal, discrete_servo_parameters(config))
    state = (np.zeros(3), np.array([steady.stroke]), initial_servo_state(steady.stroke))
    return CompiledPart(kind="control", name="governor", functions={"step": governor_discrete_servo_step},
                        params=params, state=state, signals=(),
                        hooks=PartHooks(summary={"servo_model": "discrete (Wang et al. 2023, eq. (37))",
                                                 "servo_sample_time_s": config.sample_time_s}))


def time_scales(plant, schedules) -> list:
    """The governor's servo, derivative filter and integral time while it is in control (a prescribed law has
    none); sub-stepped within the MOC step (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gov = plant.governor
    if schedules.mode != GOVERNOR:
        return []
    out = []
    if gov.servo_model != "discrete":
        out.append(TimeScale("governor.servo_time_s", gov.servo_time_s))
    if gov.kd > 0.0 and gov.derivative_filter_s > 0.0:
        # implicit Euler (first order, unlike the servo's exact exponential): 0.05 x T_f keeps the step-halving
        # change of the head rise below 0.1 point on the shipped plant
        out.append(TimeScale("governor.derivative_filter_s", gov.derivative_filter_s, resolve_fraction=0.05))
    if gov.ki > 0.0 and gov.kp > 0.0:
        out.append(TimeScale("governor integral time kp/ki", gov.kp / gov.ki))
    return out
