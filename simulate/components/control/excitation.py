"""Voltage control of the generator: PI with a first-order filter (paper 001 eqs. (11)-(13)), anti-windup.

Per unit on the machine base (terminal voltage V_g, field voltage v_f such that v_f = 1 gives 1 pu open-circuit
voltage at rated speed)::

    e_v = V_set - V_g                              eq. (11)
    T_f de_vf/dt + e_vf = e_v                      eq. (13)  (T_f = filter_s; 0 = no filter)
    v_f = kp e_vf + ki int e_vf dt                 eq. (12)  on the filtered error, clipped to [field_min, field_max]

The paper prints eq. (12) on e_v and calls e_vf both the filtered error and "the excitation voltage applied"; we
read the filter as acting on the measured error (eq. (13) as printed: its input is e_v) and the PI on the filtered
error, so a fast measurement ripple does not reach the field. The integral starts at the steady field voltage, so
the controller is incremental about the operating point as the paper's variables are.

Anti-windup: the integral is clamped to [field_min - kp e_vf, field_max - kp e_vf], so the output sits exactly on
the limit while saturated and leaves it as soon as the error changes sign (no stored excess to unwind).

Pure numba step (``cache=True``): :func:`excitation_step(params, state, terminal_voltage_pu, dt_s)` -> field
voltage for the coming step; layouts :data:`EXC_PARAMS`, :data:`EXC_STATE`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.validation import check_number
from simulate.components.parameters import parameter, validate_parameters

#: Layout of the excitation parameter vector.
EXC_PARAMS = ("kp", "ki", "filter_s", "field_min_pu", "field_max_pu", "voltage_setpoint_pu")
E_KP, E_KI, E_TF, E_MIN, E_MAX, E_VSET = range(6)
#: Layout of the excitation state vector: filtered error e_vf and the integral term (pu field voltage).
EXC_STATE = ("filtered_error_pu", "integral_pu")


@dataclass(frozen=True)
class ExcitationConfig:
    """``[excitation]``: ``kp`` (pu field per pu voltage), ``ki`` (1/s), ``filter_s`` T_f (s, 0 = none),
    ``field_min_pu`` < ``field_max_pu`` field-voltage limits, ``voltage_setpoint_pu`` V_set."""

    kp: float = parameter(unit="pu field/pu voltage", low=0.0, high=1000.0, description="proportional gain")
    ki: float = parameter(unit="pu field/(pu voltage s)", low=0.0, high=1000.0, description="integral gain")
    filter_s: float = parameter(unit="s", low=0.0, high=10.0, description="time constant T_f of the error filter")
    field_min_pu: float = parameter(unit="pu", low=-20.0, high=20.0, description="lower field-voltage limit")
    field_max_pu: float = parameter(unit="pu", low=-20.0, high=20.0, description="upper field-voltage limit")
    voltage_setpoint_pu: float = parameter(unit="pu", low=0.5, high=1.5, description="terminal-voltage set point")

    def __post_init__(self):
        validate_parameters("excitation", self)
        if self.kp == 0.0 and self.ki == 0.0:
            raise InputError("excitation.kp and excitation.ki are both 0: no voltage control (give kp > 0 or ki > 0)")
        if not self.field_min_pu < self.field_max_pu:
            raise InputError(f"excitation.field_min_pu must be < excitation.field_max_pu = {self.field_max_pu!r}, "
                             f"got {self.field_min_pu!r}")


def excitation_parameters(config: ExcitationConfig, *, voltage_setpoint_pu: float | None = None) -> np.ndarray:
    """The float vector (:data:`EXC_PARAMS`) for :func:`excitation_step`.

    Examples
    --------
    >>> c = ExcitationConfig(kp=20.0, ki=10.0, filter_s=0.02, field_min_pu=0.0, field_max_pu=5.0,
    ...                      voltage_setpoint_pu=1.0)
    >>> excitation_parameters(c).tolist()
    [20.0, 10.0, 0.02, 0.0, 5.0, 1.0]
    """
    vset = (config.voltage_setpoint_pu if voltage_setpoint_pu is None
            else check_number("excitation.voltage_setpoint_pu", voltage_setpoint_pu, low=0.5, high=1.5))
    return np.array([config.kp, config.ki, config.filter_s, config.field_min_pu, config.field_max_pu, vset])


def initial_excitation_state(config: ExcitationConfig, field_voltage_pu: float) -> np.ndarray:
    """``[0, v_f0]``: zero error, the integral holding the steady field voltage (checked against the limits)."""
    if not config.field_min_pu <= field_voltage_pu <= config.field_max_pu:
        raise InputError(f"the initial operating point needs a field voltage of {field_voltage_pu:.4g} pu, outside "
                         f"[excitation.field_min_pu, excitation.field_max_pu] = [{config.field_min_pu}, "
                         f"{config.field_max_pu}]")
    return np.array([0.0, float(field_voltage_pu)])


@numba.njit(cache=True)
def excitation_step(params, state, terminal_voltage_pu, dt_s):
    """Field voltage (pu) to hold over the coming step; updates ``state`` = [e_vf, integral] in place.

    Filter exact for an error held over the step (eq. (13)); integral by the rectangle rule on the filtered error
    (eq. (12)); clamped as described in the module docstring.

    Examples
    --------
    >>> p = np.array([20.0, 10.0, 0.0, 0.0, 5.0, 1.0]); s = np.array([0.0, 1.0])
    >>> round(float(excitation_step(p, s, 0.99, 0.1)), 6)    # 1 + 20*0.01 + 10*0.01*0.1
    1.21
    >>> round(float(excitation_step(p, s, 0.5, 0.1)), 6)     # saturates at field_max
    5.0
    """
    kp, ki, tf = params[E_KP], params[E_KI], params[E_TF]
    f_min, f_max = params[E_MIN], params[E_MAX]
    error = params[E_VSET] - terminal_voltage_pu  # eq. (11)
    if tf > 0.0:
        state[0] = error + (state[0] - error) * math.exp(-dt_s / tf)  # eq. (13)
    else:
        state[0] = error
    ef = state[0]
    integral = state[1] + ki * ef * dt_s  # eq. (12), integral part
    integral = min(max(integral, f_min - kp * ef), f_max - kp * ef)  # anti-windup clamp
    state[1] = integral
    return min(max(kp * ef + integral, f_min), f_max)  # eq. (12)


__all__ = ["ExcitationConfig", "EXC_PARAMS", "EXC_STATE", "excitation_parameters", "initial_excitation_state",
           "excitation_step"]
