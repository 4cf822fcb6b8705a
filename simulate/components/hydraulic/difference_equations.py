"""The second-order difference equations of the ``zdomain``, ``lumped`` and ``rigid`` penstock models
(:mod:`simulate.components.hydraulic.penstock`, whose docstring gives the common form): their coefficients from the
papers' transfer functions, the turbine-inlet relation they give for a step and the update of their history.
"""

from __future__ import annotations

import numba
import numpy as np



def zdomain_original(travel_time_s: float, water_time_s: float, feedback: float = 0.0):
    """Numerator and denominator (in z, highest power first, monic) of eq. (17), sampled at T_so = L/a.

    G(z) = (-1 + z^-2) / (F + C_a - (F - C_a) z^-2) with C_a = T_so / T_w (eq. (18)).

    Examples
    --------
    >>> num, den = zdomain_original(0.1, 2.0, 0.01)   # eq. (21) of the BP hill-chart paper
    >>> [round(float(v), 2) for v in num], [round(float(v), 4) for v in den]
    ([-16.67, 0.0, 16.67], [1.0, 0.0, 0.6667])
    """
    ca = travel_time_s / water_time_s  # eq. (18)
    c, d = feedback + ca, feedback - ca
    return (np.array([-1.0 / c, 0.0, 1.0 / c]), np.array([1.0, 0.0, -d / c]))  # eq. (17) times z^2 / c


def zdomain_coefficients(travel_time_s: float, water_time_s: float, step_s: float, feedback: float = 0.0):
    """``(A/C, B/C, D/C, E/C)`` of the resampled transfer function, eqs. (19)-(20) of the BP hill-chart paper:

    H_A/Q = ((A/C) z^2 + B/C) / (z^2 + (D/C) z + E/C) at the new period T_sn = ``step_s``.

    Examples
    --------
    >>> [round(float(v), 4) for v in zdomain_coefficients(0.1, 2.0, 0.01, 0.01)]   # eq. (22)
    [-3.8095, 3.8095, -1.8857, 0.9238]
    """
    t_so, t_sn = travel_time_s, step_s
    ca = t_so / water_time_s  # eq. (18)
    a_coef = -4.0 * t_sn * t_so  # eq. (20), A
    b_coef = 4.0 * t_sn * t_so  # eq. (20), B
    c_coef = 4.0 * feedback * t_sn * t_so + 2.0 * ca * (t_sn ** 2 + t_so ** 2)  # eq. (20), C
    d_coef = 4.0 * ca * (t_sn ** 2 - t_so ** 2)  # eq. (20), D
    e_coef = -4.0 * feedback * t_sn * t_so + 2.0 * ca * (t_sn ** 2 + t_so ** 2)  # eq. (20), E
    return a_coef / c_coef, b_coef / c_coef, d_coef / c_coef, e_coef / c_coef


def lumped_coefficients(water_time_s: float, travel_time_s: float, step_s: float, lumped_alpha: float) -> np.ndarray:
    """``[b0, b1, b2, a1, a2]`` (per unit) of the ``lumped`` model: scipy's bilinear (Tustin) transform of
    -Tw s / (1 + alpha Te^2 s^2) (paper 000 eq. (15)); Tustin keeps the undamped resonance undamped."""
    from scipy import signal  # lazy: scipy.signal costs about 1 s of start-up and only this model needs it

    tw, te = water_time_s, travel_time_s
    num, den, _ = signal.cont2discrete(([-tw, 0.0], [lumped_alpha * te ** 2, 0.0, 1.0]), step_s, method="bilinear")
    num = np.ravel(num)
    num = np.concatenate((np.zeros(3 - num.size), num)) / den[0]
    den = np.asarray(den, float) / den[0]
    return np.array([num[0], num[1], num[2], den[1], den[2]])


def rigid_coefficients(water_time_s: float, step_s: float) -> np.ndarray:
    """``[b0, b1, b2, a1, a2]`` (per unit) of the ``rigid`` model: backward Euler of h = -Tw dq/dt, b0 = -Tw/dt,
    b1 = Tw/dt (the trapezoidal rule would make the algebraic head alternate +-h forever once the vanes are shut,
    backward Euler does not).

    Examples
    --------
    >>> rigid_coefficients(2.0, 0.01).tolist()
    [-200.0, 200.0, 0.0, 0.0, 0.0]
    """
    return np.array([-water_time_s / step_s, water_time_s / step_s, 0.0, 0.0, 0.0])


@numba.njit(cache=True)
def iir_turbine_relation(coef, hist, static_head_m, friction_s2_m5, rated_head_m, rated_flow_m3_s, flow0_m3_s):
    """(C_L, k) of H = H_st - K Q_prev|Q_prev| + H_r h[k] with h[k] = b0 (Q - Q0)/Q_r + (known past terms).

    ``hist`` = [q[k-1], q[k-2], h[k-1], h[k-2], Q_prev (m^3/s)].
    """
    known = coef[1] * hist[0] + coef[2] * hist[1] - coef[3] * hist[2] - coef[4] * hist[3]
    q_prev = hist[4]
    base = static_head_m - friction_s2_m5 * q_prev * abs(q_prev)
    k = rated_head_m * coef[0] / rated_flow_m3_s
    return base + rated_head_m * known - k * flow0_m3_s, k


@numba.njit(cache=True)
def iir_step(coef, hist, flow_m3_s, flow0_m3_s, rated_flow_m3_s):
    """Shift the history after the turbine flow of this step is known."""
    q = (flow_m3_s - flow0_m3_s) / rated_flow_m3_s
    h = coef[0] * q + coef[1] * hist[0] + coef[2] * hist[1] - coef[3] * hist[2] - coef[4] * hist[3]
    hist[1] = hist[0]
    hist[0] = q
    hist[3] = hist[2]
    hist[2] = h
    hist[4] = flow_m3_s
