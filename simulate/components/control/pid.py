"""The governor's PID (parallel, with derivative filter and integrator clamping) on a per-unit error: the one
implementation the PID modes of ``governor.mode`` share (:mod:`simulate.components.control.governor`, ``speed``: the
permanent droop on the servo stroke; :mod:`simulate.components.control.power_governor`, ``power``: the droop on the
electrical power). Paper 000 sections 2.5-2.7.
"""

from __future__ import annotations

import numba
import numpy as np

#: Layout of the PID parameter vector passed to the compiled loop.
GOVERNOR_PARAMS = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop", "initial_stroke", "stroke_min",
                   "stroke_max")
#: The ``[governor]`` keys the PID reads (a mode that runs it requires them).
PID_KEYS = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop")


def governor_parameters(governor, initial_stroke: float) -> np.ndarray:
    """The float vector (layout :data:`GOVERNOR_PARAMS`) for :func:`pid_step` and :func:`governor_step`.

    Examples
    --------
    >>> from simulate.components.control.governor import GovernorConfig
    >>> g = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.04,
    ...                    servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    >>> governor_parameters(g, 0.8).tolist()
    [2.0, 0.5, 0.0, 0.0, 0.04, 0.8, 0.0, 1.0]
    """
    return np.array([governor.kp, governor.ki, governor.kd, governor.derivative_filter_s, governor.permanent_droop,
                     initial_stroke, governor.stroke_min, governor.stroke_max])


@numba.njit(cache=True)
def pid_step(params, state, error, dt_s):
    """Stroke command u after one step on the per-unit ``error`` e; updates ``state`` = [integral, derivative,
    e_prev].

    u = y0 + kp e + I + D, I' = ki e, T_f D' + D = kd e' (backward Euler). The command is clipped to the stroke
    limits. Anti-windup by integrator clamping: the integral stays within [stroke_min - y0, stroke_max - y0], so
    it can always bring the command back from either limit. (Back-calculation of the clipped amount would load the
    derivative kick of a reference step into the integral, which then drives the vanes the wrong way as the kick
    decays; conditional integration would freeze the integral during a long overspeed, and the proportional part
    alone would reopen the vanes while the unit is still far above speed.)

    Examples
    --------
    >>> p = np.array([2.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 1.0])
    >>> round(float(pid_step(p, np.zeros(3), 0.01, 0.1)), 4)   # 0.5 + 2*0.01 + 0.5*0.01*0.1
    0.5205
    """
    kp, ki, kd, tf = params[0], params[1], params[2], params[3]
    y0, y_min, y_max = params[5], params[6], params[7]
    state[1] = (tf * state[1] + kd * (error - state[2])) / (tf + dt_s)
    state[2] = error
    state[0] = min(max(state[0] + ki * error * dt_s, y_min - y0), y_max - y0)
    command = y0 + kp * error + state[0] + state[1]
    return min(max(command, y_min), y_max)


@numba.njit(cache=True)
def governor_step(params, state, speed_dev, speed_ref, stroke, dt_s):
    """The speed governor's command: :func:`pid_step` on e = x_ref - x - b_p (y - y0) (permanent droop on the servo
    stroke; x the per-unit speed deviation, y the stroke).

    Examples
    --------
    >>> p = np.array([2.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 1.0])
    >>> s = np.zeros(3)
    >>> round(float(governor_step(p, s, -0.01, 0.0, 0.5, 0.1)), 4)   # 0.5 + 2*0.01 + 0.5*0.01*0.1
    0.5205
    """
    error = speed_ref - speed_dev - params[4] * (stroke - params[5])
    return pid_step(params, state, error, dt_s)


def pid_time_scales(plant) -> list:
    """The derivative filter and the integral time of the PID (sub-stepped within the MOC step, see
    :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gov = plant.governor
    out = []
    if gov.kd > 0.0 and gov.derivative_filter_s > 0.0:
        # implicit Euler (first order, unlike the servo's exact exponential): 0.05 x T_f keeps the step-halving
        # change of the head rise below 0.1 point on the shipped plant
        out.append(TimeScale("governor.derivative_filter_s", gov.derivative_filter_s, resolve_fraction=0.05))
    if gov.ki > 0.0 and gov.kp > 0.0:
        out.append(TimeScale("governor integral time kp/ki", gov.kp / gov.ki))
    return out


__all__ = ["GOVERNOR_PARAMS", "PID_KEYS", "governor_parameters", "pid_step", "governor_step", "pid_time_scales"]
