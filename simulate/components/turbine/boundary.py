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

The solvers are *templates* with respect to the characteristics: called directly they take the kernel as their first
argument (compiled once per process and kernel: numba cannot cache a function with a dispatcher-typed argument). The
time loop does not call them that way: :mod:`simulate.loop.assembly` pastes their source into a generated loop module
with the kernel bound as the module global ``kernel`` (first parameter removed), so the loop and everything it calls is
cached on disk. ``opening`` is passed through to the kernel unchanged: a scalar chart opening when called directly,
the vector of controls (chart units) inside the loop, where ``kernel(params, n11, controls)`` returns
``(q11, dq11_dn11, m11, dm11_dn11)`` (the solvers read only the first two).

:func:`build_pressure_loop` builds the turbine boundary of every shipped kind of characteristics as a unit's part
(kind ``"turbine"``, :attr:`simulate.components.turbine.kinds.CharacteristicKind.boundary`): its step
:func:`turbine_step` is a template too (a :class:`simulate.components.registry.LoopTemplate`: it calls the globals
``pressure_loop``, ``newton_loop`` and ``torque_kernel`` of the loop module), with :func:`turbine_parameters` and
:func:`turbine_state` its arrays and :func:`turbine_signals` its state accessor.
"""

from __future__ import annotations

import math

import numba

OK, NOT_CONVERGED, NO_POSITIVE_HEAD, NAN = 0, 1, 2, 3
STATUS_TEXT = {OK: "converged", NOT_CONVERGED: "no convergence",
               NO_POSITIVE_HEAD: "no solution with a positive net head",
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
        # eq. (32), 0.5 (c k + root), written as 2 c C_L / (root - c k): with k <= 0 nothing cancels (a stiff
        # rigid column at a small step has |c k| >> Q, where the textbook form loses all its digits)
        return 2.0 * c * c_l / (root - c * k), True
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
#: Solvers whose iterations read Q11 only (``kernel(...)[0]``): the assembled loop gives them the characteristics'
#: flow half where there is one (:class:`simulate.components.turbine.evaluation.CompiledCharacteristics`).
FLOW_ONLY_SOLVERS = ("improved", "traditional")

#: The head of a step is accepted within max(``solver.tolerance`` x rated head, this x (|C_L| + |k Q|)): the penstock
#: relation H = C_L + k Q cannot be evaluated closer than a few ulp of its terms (a rigid column at dt = 1e-4 s has
#: |k Q| ~ 1e6 m); 64 eps leaves room for the rounding of the turbine equation.
ROUNDOFF_TOLERANCE = 64 * 2.220446049250313e-16
#: Relaxation factor applied to ``solver.relaxation`` by the first fallback of a step that did not converge.
FALLBACK_DAMPING = 0.5


#: What a failed pressure loop's message tells the user to change.
FAILURE_ADVICE = ("try solver.pressure_loop = \"newton\", a smaller solver.relaxation, more solver.max_iterations "
                  "or a looser solver.tolerance")
#: ... and when the head at the turbine falls towards zero (C_L below this fraction of the rated head).
SEPARATION_ADVICE = ("the net head at the turbine falls to zero or below, which its characteristics do not cover; "
                     "where the head at the turbine inlet reaches the vapour head the water column separates, "
                     "modelled by an MOC penstock with penstock.column_separation = \"dgcm\" or \"dvcm\" (not by "
                     "\"off\" or a rigid penstock): check the closing law, the characteristics where the run went "
                     "(the extrapolation warnings) and the penstock's size")
SEPARATION_FRACTION = 0.05


def _failure_advice(status: int, solver, c_l_m: float, rated_head_m: float) -> str:
    """The end of a pressure-loop failure message: what was tried and what to change."""
    tried = ""
    if status in (NOT_CONVERGED, NAN):
        tried = (f"; the step was retried with relaxation {FALLBACK_DAMPING * solver.relaxation:g} and by Newton"
                 if solver.fallback else "; solver.fallback = false")
    if status == NO_POSITIVE_HEAD or c_l_m < SEPARATION_FRACTION * rated_head_m:
        return f"{tried}): {SEPARATION_ADVICE}"
    return f"{tried}): {FAILURE_ADVICE}"


# ---------------------------------------------------------------------------------------------------------------
# The turbine boundary as a component of the time loop
# ---------------------------------------------------------------------------------------------------------------
def turbine_parameters(turbine, solver, *, head_floor_m: float, closed_stroke: float, control_scales):
    """``(scalars, control_scales)`` for :func:`turbine_step`: scalars = [D1 m, head floor m, head tolerance m,
    closed stroke, max iterations, relaxation, fallback (1 or 0)]; ``control_scales`` converts each control
    (fraction of its stroke) into the characteristics' unit (the guide vane: ``opening_max``)."""
    import numpy as np

    scalars = np.array([turbine.runner_diameter_m, head_floor_m, solver.tolerance * turbine.rated_head_m,
                        closed_stroke, float(solver.max_iterations), solver.relaxation,
                        1.0 if solver.fallback else 0.0])
    return scalars, np.asarray(control_scales, dtype=float)


def turbine_state(head_m: float, flow_m3_s: float, torque_nm: float, n_controls: int):
    """``(signals, controls_chart)``: signals = [head m, flow m^3/s, torque N*m] of the last step."""
    import numpy as np

    return np.array([head_m, flow_m3_s, torque_nm]), np.zeros(n_controls)


def build_pressure_loop(inputs):
    """The turbine boundary of section 4 of the BP hill-chart paper as a unit's part (kind ``"turbine"``): every
    step the pressure loop ``solver.pressure_loop`` chose (:func:`turbine_step`, pasted into the loop module with
    the characteristics' kernels, :class:`simulate.components.registry.LoopTemplate`). ``inputs``: the unit's
    :class:`simulate.components.turbine.component.BoundaryInputs`; the part's params are
    ``(scalars, control_scales, characteristics' params)`` (:func:`turbine_parameters`), its state
    ``(signals, controls_chart)`` (:func:`turbine_state`), from the steady state."""
    from simulate.components.registry import CompiledPart, LoopTemplate, PartHooks

    turbine, solver, n = inputs.turbine, inputs.solver, inputs.n_controls
    scalars, scales = turbine_parameters(turbine, solver, head_floor_m=inputs.head_floor_m,
                                         closed_stroke=inputs.closed_stroke,
                                         control_scales=[turbine.opening_max] + [1.0] * (n - 1))
    st = inputs.steady

    def step_failure(status: int, diag, conduit: str) -> tuple[str, str]:
        what = f"pressure loop '{solver.pressure_loop}' failed ({STATUS_TEXT[status]})"
        details = (f"speed {diag[1]:.6g} r/min, opening {diag[2]:.6g} (chart units), head guess {diag[3]:.6g} m, "
                   f"{conduit} relation H = {diag[4]:.6g} + ({diag[5]:.6g}) Q, last head residual {diag[6]:.3g} m "
                   f"(tolerance {scalars[2]:.3g} m, {solver.max_iterations} iterations, relaxation "
                   f"{solver.relaxation}" + _failure_advice(status, solver, diag[4], turbine.rated_head_m))
        return what, details

    return CompiledPart(kind="turbine", name="pressure_loop",
                        functions={"step": LoopTemplate(turbine_step), "signals": turbine_signals},
                        params=(scalars, scales, inputs.compiled.params),
                        state=turbine_state(st.head_m, st.flow_m3_s, st.torque_nm, n),
                        hooks=PartHooks(step_failure=step_failure))


@numba.njit(cache=True)
def turbine_signals(params, state):
    """(head m, flow m^3/s, torque N*m) after the last :func:`turbine_step`."""
    signals = state[0]
    return signals[0], signals[1], signals[2]


# a template: it calls the globals torque_kernel, pressure_loop and newton_loop of the assembled loop module
def turbine_step(tp, ts, c_l, slope, speed_rpm, controls, diag):
    """Solve the turbine boundary at ``speed_rpm`` and ``controls`` (fractions of stroke; control 0 the guide vane)
    against the penstock relation H = C_L + k Q; store head, flow and torque M11 D1^3 H in ``ts``.

    The head tolerance is the larger of the configured one and :data:`ROUNDOFF_TOLERANCE` x (|C_L| + |k Q|). A step
    that does not converge (or meets NaN) is retried with the same loop damped by :data:`FALLBACK_DAMPING` and
    4 x the iterations, then by Newton; ``diag[7]`` counts the steps a fallback solved.

    Shut guide vanes (stroke <= closed stroke) are a closed valve: Q = 0, H = C_L, no iteration. Returns
    ``(status, iterations)``; on failure ``diag[1:7]`` = speed, opening (chart units), head guess, C_L, k,
    residual.
    """
    scalars, scales, cp = tp
    signals, chart = ts
    d1, floor, tol, closed = scalars[0], scalars[1], scalars[2], scalars[3]
    max_iterations, relaxation = int(scalars[4]), scalars[5]
    for i in range(chart.size):
        chart[i] = controls[i] * scales[i]
    head_guess = signals[0]
    if controls[0] <= closed:
        head, flow, iters, residual, status = c_l, 0.0, 0, 0.0, OK
        if head < floor:
            status = NO_POSITIVE_HEAD
    else:
        # the head H = C_L + k Q is a sum of terms of size |C_L| and |k Q|: it is known to a few ulp of them only
        tol = max(tol, ROUNDOFF_TOLERANCE * (abs(c_l) + abs(slope * signals[1])))
        head, flow, iters, residual, status = pressure_loop(  # noqa: F821 (a template global, bound by the loop)
            cp, c_l, slope, speed_rpm, chart, head_guess, d1, floor, tol, max_iterations, relaxation)
        if (status == NOT_CONVERGED or status == NAN) and scalars[6] > 0.5:
            # what a careful engineer tries before giving up: the same loop damped, then Newton
            first = status
            head, flow, more, residual, status = pressure_loop(  # noqa: F821 (a template global)
                cp, c_l, slope, speed_rpm, chart, head_guess, d1, floor, tol, 4 * max_iterations,
                FALLBACK_DAMPING * relaxation)
            iters += more
            if status != OK:
                head, flow, more, residual, status = newton_loop(  # noqa: F821 (a template global)
                    cp, c_l, slope, speed_rpm, chart, head_guess, d1, floor, tol, 4 * max_iterations, 1.0)
                iters += more
            if status == OK:
                diag[7] += 1.0
            else:
                status = first
    if status != OK:
        diag[1] = speed_rpm
        diag[2] = chart[0]
        diag[3] = head_guess
        diag[4] = c_l
        diag[5] = slope
        diag[6] = residual
        return status, iters
    m11 = torque_kernel(cp, speed_rpm * d1 / math.sqrt(head), chart)  # noqa: F821 (template global, bound by the loop)
    signals[0] = head
    signals[1] = flow
    signals[2] = m11 * d1 ** 3 * head
    return status, iters
