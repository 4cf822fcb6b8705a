"""Rotor: Ta dx/dt = m_t - m_g - e_g x (per unit; torque base P_r / omega_r, speed base n_r)."""

from __future__ import annotations

import numba


@numba.njit(cache=True)
def rotor_step(speed_dev, turbine_torque_pu, load_torque_pu, self_regulation, inertia_time_s, dt_s):
    """Per-unit speed deviation after one explicit Euler step of the swing equation.

    Examples
    --------
    >>> round(rotor_step(0.0, 1.0, 0.9, 0.0, 8.0, 0.1), 6)
    0.00125
    """
    return speed_dev + dt_s * (turbine_torque_pu - load_torque_pu - self_regulation * speed_dev) / inertia_time_s
