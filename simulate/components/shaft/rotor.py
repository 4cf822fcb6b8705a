"""Rotor: Ta dx/dt = m_t - m_g - e_g x (per unit; torque base P_r / omega_r, speed base n_r)."""

from __future__ import annotations

import numba

from simulate.components.contract import SCALAR, LinearBlock, StateArray
from simulate.components.schedules import piecewise_constant
from simulate.components.signals import RPM_NM_TO_MW


#: Its state: the shaft speed.
SPEED = StateArray("speed", "r/min", "the shaft speed", SCALAR)
STATES = (SPEED,)


@numba.njit(cache=True)
def rotor_step(speed_dev, turbine_torque_pu, load_torque_pu, self_regulation, inertia_time_s, dt_s):
    """Per-unit speed deviation after one explicit Euler step of the swing equation.

    Examples
    --------
    >>> round(rotor_step(0.0, 1.0, 0.9, 0.0, 8.0, 0.1), 6)
    0.00125
    """
    return speed_dev + dt_s * (turbine_torque_pu - load_torque_pu - self_regulation * speed_dev) / inertia_time_s


# ---------------------------------------------------------------------------------------------------------------
# Component for the time loop (registry kind "shaft"; see simulate.components.registry)
# ---------------------------------------------------------------------------------------------------------------
# A shaft component owns the speed and offers
#   speed(p, s) -> speed_rpm                                   at the current step
#   step(p, s, turbine_torque_nm, t_s, dt_s) -> speed_rpm      the speed at t + dt
#   power(p, s, t_s) -> electrical_power_mw                    (optional) the named signal electrical_power_mw
@numba.njit(cache=True)
def rotor_speed(p, s):
    return s[0][0]


@numba.njit(cache=True)
def rotor_electrical_power(p, s, t_s):
    """The power the load takes at t, MW: its torque (m_g + e_g x) m_r (the swing equation's load term, with the
    schedule's values at t) times the speed."""
    scal, load_times, load_values, regulation_values = p
    n_r, m_r, eps_t, load0, reg0 = scal[0], scal[1], scal[3], scal[4], scal[5]
    speed = s[0][0]
    load = piecewise_constant(load_times, load_values, t_s + eps_t, load0)
    reg = piecewise_constant(load_times, regulation_values, t_s + eps_t, reg0)
    return (load + reg * (speed / n_r - 1.0)) * m_r * speed * RPM_NM_TO_MW


@numba.njit(cache=True)
def rotor_shaft_step(p, s, turbine_torque_nm, t_s, dt_s):
    """Swing equation with the scenario's load torque and self-regulation schedule (piecewise constant)."""
    scal, load_times, load_values, regulation_values = p
    n_r, m_r, ta, eps_t, load0, reg0 = scal[0], scal[1], scal[2], scal[3], scal[4], scal[5]
    x = s[0][0] / n_r - 1.0
    load = piecewise_constant(load_times, load_values, t_s + eps_t, load0)
    reg = piecewise_constant(load_times, regulation_values, t_s + eps_t, reg0)
    x_next = rotor_step(x, turbine_torque_nm / m_r, load, reg, ta, dt_s)
    speed = n_r * (1.0 + x_next)
    s[0][0] = speed
    return speed


def build_rotor(plant, steady, dt_s: float, schedules):
    """The rotor of :class:`simulate.config.GeneratorConfig` (Ta, e_g) with the scenario's load schedule."""
    import numpy as np

    from simulate.components.registry import CompiledPart

    t = plant.turbine
    scal = np.array([t.rated_speed_rpm, t.rated_torque_nm, plant.generator.inertia_time_s, 1e-9 * dt_s,
                     schedules.initial_load, schedules.initial_self_regulation])
    params = (scal, schedules.load_times_s, schedules.load_values, schedules.self_regulation_values)
    return CompiledPart(kind="shaft", name="rotor", functions={"speed": rotor_speed, "step": rotor_shaft_step,
                                                               "power": rotor_electrical_power},
                        params=params, state=(np.array([steady.speed_rpm]),))


def time_scales(plant, schedules) -> list:
    """The inertia time Ta: the rotor meets the turbine torque once per step (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    return [TimeScale("generator.inertia_time_s (Ta)", plant.generator.inertia_time_s, coupled=True)]


def linear_counterpart(plant, steady) -> LinearBlock:
    """The swing equation about the steady state in paper 000's increments (x = dn/n0, m = dM/M0): the per-unit
    rotor ``Ta d(n/n_r)/dt = (M - M_g)/M_r - e_g (n/n_r - 1)`` becomes ``J dx/dt = m - e x - m_g0`` (eqs. (8),
    (13)) with J = Ta (M_r/M0) (n0/n_r) and e = e_g (M_r/M0) (n0/n_r); e_g of the load at the steady torque
    (:meth:`simulate.config.PlantConfig.rotor_self_regulation`: the swing rotor's ``self_regulation``, the island's
    frequency dependence of the sub-transient machine)."""
    turbine = plant.turbine
    torque_ratio = turbine.rated_torque_nm / steady.torque_nm  # M_r / M0
    values = {"inertia_time_s": plant.generator.inertia_time_s * torque_ratio * steady.speed_rpm
              / turbine.rated_speed_rpm,
              "self_regulation": (plant.rotor_self_regulation(steady.torque_nm / turbine.rated_torque_nm)
                                  * torque_ratio * steady.speed_rpm / turbine.rated_speed_rpm)}
    return LinearBlock("J dx/dt = m - e x - m_g0 (paper 000 eqs. (8), (13))", values,
                       {"inertia_time_s": "s", "self_regulation": "pu torque/pu speed"})
