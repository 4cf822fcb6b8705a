"""Governor mode ``power`` (``governor.mode``): speed control with the permanent droop on the electrical power
instead of the servo stroke, the mode of a grid-connected unit.

The PID of the speed mode (:func:`simulate.components.control.pid.pid_step`) on the error::

    e = x_ref - x - b_p (P - P_ref)

x = n / n_r - 1 (the signal ``speed_rpm``), P the electrical power (the signal ``electrical_power_mw``: the swing
rotor's load, the sub-transient machine's terminal power) per unit of the turbine's rated power, b_p =
``permanent_droop`` (per-unit speed per per-unit power), x_ref the scenario's speed reference and P_ref
``power_reference_mw`` / P_r (default: the initial electrical power, the load the unit was set to). With the
integral at rest e = 0: a frequency deviation x - x_ref = df settles the power at P = P_ref - df / b_p, whatever
the stroke that takes (the speed mode settles the stroke at y0 - df / b_p instead).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from simulate.components.control.pid import PID_KEYS, governor_parameters, pid_step, pid_time_scales
from simulate.components.contract import LinearBlock
from simulate.components.control.servo import build_vane_servo, first_order_servo_step
from simulate.components.control.speed_governor import CONTROLS, PID_STATE, SERVO_STATE, pid_block
from simulate.components.parameters import own_keys, parameter
from simulate.components.registry import Bound, CompiledPart, PartHooks
from simulate.components.schedules import piecewise_constant
from simulate.components.signals import signal_indices


@dataclass(frozen=True)
class PowerModeConfig:
    """The power mode's own key of ``[governor]``."""

    power_reference_mw: float | None = parameter(None, unit="MW", low=0.0, high=1e5,
                                                 description="power reference P_ref of mode power (default: the "
                                                             "initial electrical power)")


#: Its own key of ``[governor]`` (refused under another mode), and the keys it reads, and those it requires.
OWN_KEYS = own_keys(PowerModeConfig)
GOVERNOR_KEYS = PID_KEYS + tuple(d.name for d in OWN_KEYS)
REQUIRED_KEYS = PID_KEYS
#: The named signals it reads (:data:`simulate.components.signals.SIGNALS`).
READS = ("speed_rpm", "electrical_power_mw")
#: Its state: the PID's, the servo's, the control vector.
STATES = (PID_STATE, SERVO_STATE, CONTROLS)
#: Layout of its scalars: rated speed (r/min), time epsilon (s), rated power (MW), P_ref (per unit).
_N_R, _EPS, _P_R, _P_REF = range(4)
#: The servo its step calls (bound by the builder, :class:`simulate.components.registry.Bound`).
vane_servo = first_order_servo_step


@numba.njit(cache=True)
def power_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """The PID on e = x_ref - x - b_p (P - P_ref) (module docstring) at t, then the servo: controls at t_next."""
    gov, ref_times, ref_values, scal, servo, reads = p
    state, servo_state, controls = s
    x = sig[reads[0]] / scal[_N_R] - 1.0
    power = sig[reads[1]] / scal[_P_R]
    x_ref = piecewise_constant(ref_times, ref_values, t_s + scal[_EPS], 0.0)
    command = pid_step(gov, state, x_ref - x - gov[4] * (power - scal[_P_REF]), dt_s)
    controls[0] = vane_servo(servo, servo_state, command, controls[0], dt_s)
    return controls


def build_power_governor(plant, steady, dt_s: float, schedules):
    """The power mode's control part; P_ref from ``governor.power_reference_mw`` or the steady state's power."""
    gov, t = plant.governor, plant.turbine
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    reference = steady.power_mw if gov.power_reference_mw is None else gov.power_reference_mw
    scal = np.array([t.rated_speed_rpm, 1e-9 * dt_s, t.rated_power_mw, reference / t.rated_power_mw])
    params = (governor_parameters(gov, steady.stroke), schedules.ref_times_s, schedules.ref_values, scal,
              servo.params, signal_indices(READS, "governor.mode = 'power'"))
    state = (np.zeros(3), servo.state, np.array([steady.stroke]))
    summary = {**servo.summary, "governor_mode": "power", "power_reference_mw": float(reference)}
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(power_control_step, (("vane_servo", servo.step),))},
                        params=params, state=state, hooks=PartHooks(summary=summary, reads=READS))


def time_scales(plant, schedules) -> list:
    """The PID's (:func:`simulate.components.control.pid.pid_time_scales`)."""
    return pid_time_scales(plant)


def linear_counterpart(plant, steady) -> LinearBlock:
    """The PID with the droop on the electrical power (the module docstring's equation)."""
    return pid_block(plant.governor, "u = kp e + ki/s e + kd s/(1 + T_f s) e, e = x_ref - x - b_p (P - P_ref)",
                     "pu speed/pu power")


__all__ = ["PowerModeConfig", "OWN_KEYS", "GOVERNOR_KEYS", "REQUIRED_KEYS", "READS", "power_control_step",
           "build_power_governor", "STATES", "time_scales", "linear_counterpart"]
