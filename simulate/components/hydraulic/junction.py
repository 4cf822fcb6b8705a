"""The manifold: a junction where the common conduit meets the branches of the units.

At the junction the head is common and the flows balance (the standard MOC boundary of a series or branching junction,
Wylie and Streeter, *Fluid Transients in Systems*, section 3.5):

    common conduit:  H = C_L + k Q_c              (its relation at its downstream end, k <= 0; MOC: C_L = C_P, k = -B)
    branch i:        H = C_M,i + B_i Q_i          (the C- characteristic of its first reach, Q_i into the branch)
    mass balance:    Q_c = sum_i Q_i

so H (1 - k sum 1/B_i) = C_L - k sum C_M,i / B_i. The common conduit is any penstock component (its ``relation`` and
``update``, with the manifold as its downstream end); each branch is a MOC pipe whose upstream boundary is the
manifold head (:func:`simulate.components.hydraulic.penstock.moc_step` then gives it the flow (H - C_M,i) / B_i by the
same C- line) and whose downstream end is its unit's turbine.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def manifold_solve(c_l, k, c_m, b, flows):
    """Head at the manifold (m) and the common conduit's flow (m^3/s) from the common relation ``H = c_l + k Q_c``
    and the branches' C- lines ``H = c_m[i] + b[i] Q_i``; ``flows[i]`` receives Q_i (m^3/s, into branch i).

    Examples
    --------
    >>> flows = np.zeros(2)
    >>> h, q = manifold_solve(100.0, -10.0, np.array([90.0, 90.0]), np.array([20.0, 20.0]), flows)
    >>> round(float(h), 9), round(float(q), 9), flows.tolist()   # H = 100 - 10 Q, Q = 2 (H - 90) / 20
    (95.0, 0.5, [0.25, 0.25])
    """
    s_inv = 0.0
    s_c = 0.0
    for i in range(c_m.size):
        s_inv += 1.0 / b[i]
        s_c += c_m[i] / b[i]
    head = (c_l - k * s_c) / (1.0 - k * s_inv)
    total = 0.0
    for i in range(c_m.size):
        q = (head - c_m[i]) / b[i]
        flows[i] = q
        total += q
    return head, total


# a branch as a component of the multi-unit loop: the MOC penstock's functions (relation, update, envelope, and
#   inlet_relation(p, s) -> (C_M, B), the C- line at its upstream end, the manifold, with the pipe's friction model:
#   :func:`simulate.components.hydraulic.penstock.moc_inlet_relation` as its builder binds it), plus
#   inlet_head(p, s) -> H               its head at the manifold after the update
@numba.njit(cache=True)
def moc_inlet_head(p, s):
    """Head at the inlet node of a MOC pipe after the last update, m."""
    return s[0][s[2][0], 0]


@numba.njit(cache=True)
def moc_outlet_flow(p, s):
    """Flow at the outlet node of a MOC pipe after the last update, m^3/s."""
    flows = s[1][s[2][0]]
    return flows[flows.size - 1]


@numba.njit(cache=True)
def moc_outlet_head(p, s):
    """Head at the outlet node of a MOC pipe after the last update, m."""
    heads = s[0][s[2][0]]
    return heads[heads.size - 1]


def manifold_state(n_units: int):
    """``(c_m, b, flows)``: the work arrays of :func:`manifold_solve` for ``n_units`` branches."""
    return np.zeros(n_units), np.zeros(n_units), np.zeros(n_units)
