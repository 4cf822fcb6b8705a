"""Governor mode ``dashpot`` (``governor.mode``): the transient-droop (dashpot) governor of OpenHPL's
``Controllers/Governor`` model (after Sharefi 2011; the equations in its equation section)::

    e = x_ref - x - b_p (y - y0) - (delta y - x_r)      droop and dashpot feedback (OpenHPL: e = 1 - f/f_ref - dd
                                                          + droop (Y_gv_ref - Y_gv), dd = delta Y_gv - x_r)
    T_r x_r' + x_r = delta y                            the dashpot (OpenHPL: T_r der(x_r) + x_r = delta Y_gv)
    T_p u' + u = e                                      the pilot servo (OpenHPL: T_p der(u) + u = e)
    Y' = u / T_g                                        the main servo's integrator (OpenHPL: der(Y_gv) = u / T_g)

x = n / n_r - 1 (the signal ``speed_rpm``), y the vane stroke, y0 its initial value, b_p = ``permanent_droop``,
delta = ``transient_droop``, T_r = ``dashpot_time_s``, T_p = ``pilot_servo_time_s``, T_g = ``gate_servo_time_s``.
OpenHPL's Y_gv is the vane opening itself with its rate and range limits; here the integrator's output Y (held in
[stroke_min, stroke_max]: anti-windup) is the stroke command of the servo ``governor.servo_model``, whose lag, rate
and stroke limits then act as in the other modes (a small ``servo_time_s`` gives OpenHPL's chain). The dashpot term
delta y - x_r decays as the stroke settles, so at rest u = 0, e = 0 and x = x_ref - b_p (y - y0): the permanent
droop's steady state. Each first-order lag is integrated exactly over a step for its input held (the servo's
scheme); the integrator by explicit Euler.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from simulate.components.contract import ENTRIES, LinearBlock, StateArray
from simulate.components.control.servo import build_vane_servo, first_order_servo_step
from simulate.components.control.speed_governor import CONTROLS, SERVO_STATE
from simulate.components.parameters import own_keys, parameter
from simulate.components.registry import Bound, CompiledPart, PartHooks
from simulate.components.schedules import piecewise_constant
from simulate.components.signals import signal_indices


@dataclass(frozen=True)
class DashpotConfig:
    """The dashpot mode's own keys of ``[governor]``."""

    transient_droop: float = parameter(unit="pu speed/stroke", low=0.0, low_open=True, high=5.0,
                                       description="transient droop delta of mode dashpot")
    dashpot_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="dashpot (reset) time T_r of mode dashpot")
    pilot_servo_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=10.0,
                                          description="pilot servo time constant T_p of mode dashpot")
    gate_servo_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                         description="main servo integration time T_g of mode dashpot")


#: Its own keys of ``[governor]`` (refused under another mode), and the keys it reads (all required): the
#: permanent droop, which the PID modes read too, and its own.
OWN_KEYS = own_keys(DashpotConfig)
GOVERNOR_KEYS = ("permanent_droop",) + tuple(d.name for d in OWN_KEYS)
REQUIRED_KEYS = GOVERNOR_KEYS
#: The named signals it reads (:data:`simulate.components.signals.SIGNALS`).
READS = ("speed_rpm",)
#: Layout of its parameter vector.
DASHPOT_PARAMS = ("rated_speed_rpm", "time_eps_s", "permanent_droop", "transient_droop", "initial_stroke",
                  "dashpot_decay", "pilot_decay", "gate_gain_per_step", "stroke_min", "stroke_max")
(_N_R, _EPS, _BP, _DELTA, _Y0, _DASHPOT_DECAY, _PILOT_DECAY, _GATE_GAIN, _Y_MIN, _Y_MAX) = range(len(DASHPOT_PARAMS))
#: Layout of its state vector: dashpot x_r, pilot servo u, main servo's integrator Y.
_XR, _U, _Y = 0, 1, 2
#: Its state: the dashpot's, the pilot servo's and the integrator's, the servo's, the control vector.
STATES = (StateArray("dashpot", "pu speed; pu speed; stroke", "the dashpot x_r, the pilot servo u, the main servo's "
                     "integrator Y", ENTRIES, entries=("dashpot", "pilot_servo", "integrator")),
          SERVO_STATE, CONTROLS)
#: The servo its step calls (bound by the builder, :class:`simulate.components.registry.Bound`).
vane_servo = first_order_servo_step


@numba.njit(cache=True)
def dashpot_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """One step of the module docstring's equations at t, then the servo: controls at t_next."""
    par, ref_times, ref_values, servo, reads = p
    state, servo_state, controls = s
    x = sig[reads[0]] / par[_N_R] - 1.0
    x_ref = piecewise_constant(ref_times, ref_values, t_s + par[_EPS], 0.0)
    y = controls[0]
    error = x_ref - x - par[_BP] * (y - par[_Y0]) - (par[_DELTA] * y - state[_XR])
    state[_U] = error + (state[_U] - error) * par[_PILOT_DECAY]
    state[_Y] = min(max(state[_Y] + par[_GATE_GAIN] * state[_U], par[_Y_MIN]), par[_Y_MAX])
    state[_XR] = par[_DELTA] * y + (state[_XR] - par[_DELTA] * y) * par[_DASHPOT_DECAY]
    controls[0] = vane_servo(servo, servo_state, state[_Y], controls[0], dt_s)
    return controls


def dashpot_parameters(plant, initial_stroke: float, dt_s: float) -> np.ndarray:
    """The float vector (layout :data:`DASHPOT_PARAMS`) at the control step ``dt_s``."""
    gov = plant.governor
    return np.array([plant.turbine.rated_speed_rpm, 1e-9 * dt_s, gov.permanent_droop, gov.transient_droop,
                     initial_stroke, math.exp(-dt_s / gov.dashpot_time_s), math.exp(-dt_s / gov.pilot_servo_time_s),
                     dt_s / gov.gate_servo_time_s, gov.stroke_min, gov.stroke_max])


def build_dashpot_governor(plant, steady, dt_s: float, schedules):
    """The dashpot mode's control part, at rest at t = 0 (x_r = delta y0, u = 0, Y = y0)."""
    gov = plant.governor
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    params = (dashpot_parameters(plant, steady.stroke, dt_s), schedules.ref_times_s, schedules.ref_values,
              servo.params, signal_indices(READS, "governor.mode = 'dashpot'"))
    state = (np.array([gov.transient_droop * steady.stroke, 0.0, steady.stroke]), servo.state,
             np.array([steady.stroke]))
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(dashpot_control_step, (("vane_servo", servo.step),))},
                        params=params, state=state,
                        hooks=PartHooks(summary={**servo.summary, "governor_mode": "dashpot"}, reads=READS))


def time_scales(plant, schedules) -> list:
    """The pilot servo's T_p and the dashpot's T_r (sub-stepped within the MOC step, see
    :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gov = plant.governor
    return [TimeScale("governor.pilot_servo_time_s", gov.pilot_servo_time_s),
            TimeScale("governor.dashpot_time_s", gov.dashpot_time_s)]


def linear_counterpart(plant, steady) -> LinearBlock:
    """The module docstring's equations without their limits (OpenHPL's transient-droop governor): the numbers of
    the droops and the three time constants."""
    gov = plant.governor
    values = {"permanent_droop": gov.permanent_droop, "transient_droop": gov.transient_droop,
              "dashpot_time_s": gov.dashpot_time_s, "pilot_servo_time_s": gov.pilot_servo_time_s,
              "gate_servo_time_s": gov.gate_servo_time_s}
    units = {"permanent_droop": "pu speed/stroke", "transient_droop": "pu speed/stroke", "dashpot_time_s": "s",
             "pilot_servo_time_s": "s", "gate_servo_time_s": "s"}
    return LinearBlock("e = x_ref - x - b_p (y - y0) - (delta y - x_r), T_r x_r' + x_r = delta y, T_p u' + u = e, "
                       "Y' = u / T_g (OpenHPL Controllers/Governor)", values, units)


__all__ = ["DashpotConfig", "OWN_KEYS", "GOVERNOR_KEYS", "REQUIRED_KEYS", "READS", "DASHPOT_PARAMS",
           "dashpot_control_step", "dashpot_parameters", "build_dashpot_governor", "STATES", "time_scales",
           "linear_counterpart"]
