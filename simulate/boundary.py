"""Turbine boundary: the pressure loop of section 4 of the BP hill-chart paper (004).

Every step the head H (m) and flow Q (m^3/s) at the turbine inlet satisfy both

    penstock:  H = C_L + k Q,  k <= 0                      (eq. (26), written in physical units)
    turbine:   Q = Q11(N11, a) D1^2 sqrt(H),  N11 = n D1 / sqrt(H)      (eqs. (23)-(24))

Three solvers with one signature ``solver(kernel, params, c_l, k, speed_rpm, opening, head_guess_m, d1_m,
head_floor_m, head_tol_m, max_iterations, relaxation) -> (head_m, flow_m3_s, iterations, residual_m, status)``:

``solve_traditional``  relaxed fixed point on the head, eqs. (27)-(28): xi <- alpha D_h(xi) + (1 - alpha) xi with
                       D_h(xi) = C_L + k Q(xi). (The paper prints ``alpha phi(xi)``; phi vanishes at the solution,
                       so the fixed-point map D_h is what is meant.) It converges only while
                       alpha |dD_h/dH| is small: with an elastic penstock |k dQ/dH| is often > 1.
``solve_improved``     eqs. (29)-(32): for a given N11 the two equations give a quadratic in Q solved in closed form,
                       so the iteration runs only through N11(H), which Q11 depends on weakly.
``solve_newton``       Newton on F(H) = C_L + k Q(H) - H with the analytic dQ11/dN11 of the characteristics.

All return H = C_L + k Q (the penstock relation exactly) and stop when |H_new - H_old| <= head_tol_m.

Guards (no NaN): at a = 0 the kernel gives Q11 = 0, so Q = 0 and H = C_L in one step. Iterates are kept at or above
``head_floor_m``; if the equations have no solution with H >= head_floor_m (C_L below the floor with forward flow,
or no real root for reverse flow), the head at the turbine would be at or below zero, i.e. the water column would
separate, which this model does not represent: status 2. Reverse flow (Q11 < 0) takes the negative root of the
quadratic. Status 1: no convergence within ``max_iterations``. Status 3: the kernel returned NaN.

These functions take the kernel as an argument, so numba cannot cache them (a dispatcher-typed argument makes a new
cache entry per process); they are compiled once per process and kernel.
"""

from __future__ import annotations

import math

import numba

OK, NOT_CONVERGED, NO_POSITIVE_HEAD, NAN = 0, 1, 2, 3
STATUS_TEXT = {OK: "converged", NOT_CONVERGED: "no convergence",
               NO_POSITIVE_HEAD: "no solution with positive head (water-column separation is not modelled)",
               NAN: "the characteristics returned NaN"}


@numba.njit(cache=True)
def quadratic_flow(unit_flow, d1_m, c_l, k):
    """Q from eq. (32) in physical units: Q^2 - c k Q - c C_L = 0 with c = Q11^2 D1^4, the root with the sign of
    Q11. Returns (Q, ok); ok is False when no root gives a positive head.

    Examples
    --------
    >>> q, ok = quadratic_flow(0.5, 2.0, 100.0, 0.0)   # no penstock compliance: Q = Q11 D1^2 sqrt(C_L)
    >>> float(q), bool(ok)
    (20.0, True)
    """
    c = unit_flow * unit_flow * d1_m ** 4
    if c == 0.0:
        return 0.0, c_l > 0.0
    disc = c * c * k * k + 4.0 * c * c_l
    if disc < 0.0 or (unit_flow > 0.0 and c_l <= 0.0):
        return 0.0, False
    root = math.sqrt(disc)
    if unit_flow > 0.0:
        return 0.5 * (c * k + root), True  # eq. (32)
    return 0.5 * (c * k - root), True  # reverse flow: the negative root


@numba.njit(cache=False)
def solve_improved(kernel, params, c_l, k, speed_rpm, opening, head_guess_m, d1_m, head_floor_m, head_tol_m,
                   max_iterations, relaxation):
    """Improved pressure loop, eqs. (29)-(32) of the BP hill-chart paper (see module docstring)."""
    xi = max(head_guess_m, head_floor_m)
    residual = math.inf
    for it in range(1, max_iterations + 1):
        n11 = speed_rpm * d1_m / math.sqrt(xi)  # eq. (23)
        q11 = kernel(params, n11, opening)[0]
        if q11 != q11:
            return xi, 0.0, it, residual, NAN
        flow, ok = quadratic_flow(q11, d1_m, c_l, k)  # eq. (32)
        if not ok:
            return xi, flow, it, residual, NO_POSITIVE_HEAD
        head = c_l + k * flow  # eq. (26)
        residual = abs(head - xi)
        if residual <= head_tol_m:
            if head < head_floor_m:
                return head, flow, it, residual, NO_POSITIVE_HEAD
            return head, flow, it, residual, OK
        xi = max(relaxation * head + (1.0 - relaxation) * xi, head_floor_m)
    return xi, 0.0, max_iterations, residual, NOT_CONVERGED


@numba.njit(cache=False)
def solve_traditional(kernel, params, c_l, k, speed_rpm, opening, head_guess_m, d1_m, head_floor_m, head_tol_m,
                      max_iterations, relaxation):
    """Traditional relaxed fixed point on the head, eqs. (27)-(28) of the BP hill-chart paper."""
    xi = max(head_guess_m, head_floor_m)
    residual = math.inf
    for it in range(1, max_iterations + 1):
        sqrt_h = math.sqrt(xi)
        q11 = kernel(params, speed_rpm * d1_m / sqrt_h, opening)[0]  # eq. (23)
        if q11 != q11:
            return xi, 0.0, it, residual, NAN
        flow = q11 * d1_m * d1_m * sqrt_h  # eq. (24)
        head = c_l + k * flow  # eq. (28), D_h(xi)
        residual = abs(head - xi)  # |phi(xi)|, eq. (27)
        if residual <= head_tol_m:
            if head < head_floor_m:
                return head, flow, it, residual, NO_POSITIVE_HEAD
            return head, flow, it, residual, OK
        xi = max(relaxation * head + (1.0 - relaxation) * xi, head_floor_m)
    return xi, 0.0, max_iterations, residual, NOT_CONVERGED


@numba.njit(cache=False)
def solve_newton(kernel, params, c_l, k, speed_rpm, opening, head_guess_m, d1_m, head_floor_m, head_tol_m,
                 max_iterations, relaxation):
    """Newton on F(H) = C_L + k Q(H) - H, dQ/dH = D1^2 (Q11 / (2 sqrt H) - dQ11/dN11 N11 / (2 sqrt H)).

    ``relaxation`` is not used (Newton steps are only cut to keep H above the floor).
    """
    head = max(head_guess_m, head_floor_m)
    residual = math.inf
    d1_sq = d1_m * d1_m
    for it in range(1, max_iterations + 1):
        sqrt_h = math.sqrt(head)
        n11 = speed_rpm * d1_m / sqrt_h
        out = kernel(params, n11, opening)
        q11, dq_dn11 = out[0], out[1]
        if q11 != q11 or dq_dn11 != dq_dn11:
            return head, 0.0, it, residual, NAN
        flow = q11 * d1_sq * sqrt_h
        new_head = c_l + k * flow
        residual = abs(new_head - head)
        if residual <= head_tol_m:
            if new_head < head_floor_m:
                return new_head, flow, it, residual, NO_POSITIVE_HEAD
            return new_head, flow, it, residual, OK
        # dN11/dH = -N11 / (2 H), so dQ/dH = D1^2 (Q11 - dQ11/dN11 N11) / (2 sqrt H)
        dflow_dh = d1_sq * (q11 - dq_dn11 * n11) / (2.0 * sqrt_h)
        slope = k * dflow_dh - 1.0
        step = -(new_head - head) / slope if slope != 0.0 else new_head - head
        head = max(head + step, 0.5 * head, head_floor_m)
    return head, 0.0, max_iterations, residual, NOT_CONVERGED


SOLVERS = {"improved": solve_improved, "traditional": solve_traditional, "newton": solve_newton}
