"""Governor mode ``speed`` (``governor.mode``, the default): paper 000 sections 2.5-2.7's parallel PID on the
per-unit speed error with the permanent droop on the servo stroke
(:func:`simulate.components.control.pid.governor_step`), then the servo ``governor.servo_model``::

    e = x_ref - x - b_p (y - y0),   u = y0 + kp e + ki int e dt + kd s / (1 + T_f s) e

x = n / n_r - 1 (the signal ``speed_rpm``), x_ref the scenario's speed reference, y the vane stroke, y0 its initial
value.
"""

from __future__ import annotations

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import ENTRIES, PART, PER_CONTROL, LinearBlock, StateArray
from simulate.components.control.pid import PID_KEYS, governor_parameters, governor_step, pid_time_scales
from simulate.components.control.servo import build_vane_servo, first_order_servo_step
from simulate.components.registry import Bound, CompiledPart, PartHooks
from simulate.components.schedules import piecewise_constant
from simulate.components.signals import signal_indices

#: The ``[governor]`` keys the speed mode reads (all required).
GOVERNOR_KEYS = PID_KEYS
REQUIRED_KEYS = PID_KEYS
#: What the speed mode reads (names of :data:`simulate.components.signals.SIGNALS`).
READS = ("speed_rpm",)
#: The servo the governor's step calls: its builder binds the plant's (:class:`Bound`); this default, the first-order
#: servo, serves a call of the step outside the assembled loop.
vane_servo = first_order_servo_step

#: The PID's state (:func:`simulate.components.control.pid.pid_step`).
PID_STATE = StateArray("pid", "stroke; stroke; pu speed", "the PID's integral, its filtered derivative and the "
                       "last error", ENTRIES, entries=("integral", "derivative", "previous_error"))
#: The governor's servo (``governor.servo_model``), its state declared by the servo's module.
SERVO_STATE = StateArray("servo", "", "the servo's state", PART, kind="servo", chosen_by="governor.servo_model")
#: The control vector (stroke fractions; the last array of every control part).
CONTROLS = StateArray("controls", "stroke fraction", "the control vector: the guide-vane stroke (and the runner "
                      "blades' with a combinator)", PER_CONTROL)
STATES = (PID_STATE, SERVO_STATE, CONTROLS)


@numba.njit(cache=True)
def governor_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """Governor PID on the speed at t (the signal ``speed_rpm``), then the guide-vane servo (``vane_servo``):
    controls at t_next."""
    gov, ref_times, ref_values, scal, servo, reads = p
    state, servo_state, controls = s
    x = sig[reads[0]] / scal[0] - 1.0
    x_ref = piecewise_constant(ref_times, ref_values, t_s + scal[1], 0.0)
    command = governor_step(gov, state, x, x_ref, controls[0], dt_s)
    controls[0] = vane_servo(servo, servo_state, command, controls[0], dt_s)
    return controls


def build_speed_governor(plant, steady, dt_s: float, schedules):
    """Mode ``speed``: the PID on the speed with the droop on the stroke, then the servo; the speed reference
    follows the scenario's schedule."""
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    scal = np.array([plant.turbine.rated_speed_rpm, 1e-9 * dt_s])
    params = (governor_parameters(plant.governor, steady.stroke), schedules.ref_times_s, schedules.ref_values, scal,
              servo.params, signal_indices(READS, "governor.mode = 'speed'"))
    state = (np.zeros(3), servo.state, np.array([steady.stroke]))
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(governor_control_step, (("vane_servo", servo.step),))},
                        params=params, state=state, signals=(),
                        hooks=PartHooks(summary=dict(servo.summary), reads=READS))


def time_scales(plant, schedules) -> list:
    """The PID's (:func:`simulate.components.control.pid.pid_time_scales`)."""
    return pid_time_scales(plant)


def linear_counterpart(plant, steady) -> LinearBlock:
    """The PID with the droop on the stroke (the module docstring's equation, paper 000 sections 2.5-2.7)."""
    return pid_block(plant.governor, "u = kp e + ki/s e + kd s/(1 + T_f s) e, e = x_ref - x - b_p (y - y0) "
                                     "(paper 000 sections 2.5-2.7)", "pu speed/stroke")


def pid_block(governor, equation: str, droop_unit: str) -> LinearBlock:
    """The PID's :class:`LinearBlock` (its gains, filter and droop) of the ``[governor]`` section."""
    values = {"kp": governor.kp, "ki": governor.ki, "kd": governor.kd,
              "derivative_filter_s": governor.derivative_filter_s, "permanent_droop": governor.permanent_droop}
    units = {"kp": "stroke/pu speed", "ki": "stroke/(pu speed s)", "kd": "stroke s/pu speed",
             "derivative_filter_s": "s", "permanent_droop": droop_unit}
    return LinearBlock(equation, values, units)


def refuse_speed_steps(mode: str, doing: str, plant, schedules) -> None:
    """:class:`InputError` for a mode without a speed reference (``doing``: what it does instead) under a scenario
    that steps the speed reference: the steps would be ignored."""
    if np.any(schedules.ref_values != 0.0):
        raise InputError(f"governor.mode = {mode!r} {doing} and has no speed reference: the speed steps of "
                         f"scenario.kind = {plant.scenario.kind!r} would be ignored; use governor.mode = 'speed' "
                         f"(or 'power', 'dashpot') for this scenario")


__all__ = ["GOVERNOR_KEYS", "REQUIRED_KEYS", "READS", "PID_STATE", "SERVO_STATE", "CONTROLS", "STATES",
           "governor_control_step", "build_speed_governor", "time_scales", "linear_counterpart", "pid_block",
           "refuse_speed_steps"]
