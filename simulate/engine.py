"""The time loop: one numba-compatible implementation for every penstock model, pressure loop and scenario.

Per step k -> k+1 (t = k dt):

1. control: governor PID + servo on (x_k, y_k), or the prescribed stroke at t_{k+1};
2. rotor: x_{k+1} from the turbine torque and load at t_k (explicit Euler);
3. penstock: the linear relation H = C_L + k Q at the turbine from the penstock state at t_k;
4. turbine boundary: (H, Q) at n_{k+1}, a_{k+1} by the chosen pressure loop; turbine torque M11 D1^3 H;
5. penstock update with (H, Q).

The loop takes ``(kernel, params)`` from :func:`hillchart.characteristics.scalar_kernel` and the pressure-loop
function as arguments. With a numba kernel it runs compiled; otherwise the very same source runs as
``_time_loop.py_func`` with the Python kernel and ``solver.py_func``. Functions that take the kernel are not cached
by numba (a dispatcher argument makes a fresh cache entry per process), so they compile once per process.
"""

from __future__ import annotations

import math
import time as _time

import numba
import numpy as np

from hillchart.characteristics import scalar_kernel
from hillchart.errors import InputError, NumericalError
from simulate.boundary import SOLVERS, STATUS_TEXT
from simulate.config import PlantConfig, load_characteristics
from simulate.governor import governor_parameters, governor_step, piecewise_constant, piecewise_linear, servo_step
from simulate.penstock import (build_moc_grid, iir_coefficients, iir_step, iir_turbine_relation, moc_steady_state,
                               moc_step, moc_turbine_relation)
from simulate.result import SimulationResult
from simulate.rotor import rotor_step
from simulate.scenarios import build_schedules, initial_target
from simulate.steady import SteadyState, steady_state

#: Lowest head (fraction of rated) the pressure loop accepts; below it the column would separate.
HEAD_FLOOR_FRACTION = 1e-4
#: Stroke at or below which the guide vanes are shut: the boundary is a closed valve, Q = 0 and H = C_L, whatever
#: the characteristics say. A fitted net has a small Q11 at a = 0 (the shipped nets: about -0.002 m^3/s, varying
#: with N11); with dQ/dH < 0 that "leak" is a negative resistance that pumps the water hammer in a shut penstock.
#: The servo approaches its end stop exponentially, so "shut" is 1e-6 of the stroke, not exactly 0.
CLOSED_STROKE = 1e-6

# layout of the float vector ``plant`` passed to the loop
_D1, _N_R, _H_R, _Q_R, _M_R, _A_MAX, _TA, _H_FLOOR, _H_TOL, _H_ST, _K_F, _Q0, _Y_CLOSED = range(13)


@numba.njit(cache=False)
def _time_loop(kernel, params, solver, n_steps, dt, plant, is_moc, heads, flows, impedance, friction, iir_coef,
               iir_hist, mode, gov_params, gov_state, law_times, law_strokes, ref_times, ref_values, load_times,
               load_values, reg_values, load0, reg0, max_iterations, relaxation,
               out_speed, out_head, out_flow, out_stroke, out_torque, out_iter, diag):
    """Advance ``n_steps`` steps; rows 0 of the ``out_*`` arrays hold the initial state. Returns (status, rows).

    On failure ``diag`` = [t, speed, opening, head_guess, C_L, k, residual] of the failing step.
    """
    d1, n_r, a_max, ta = plant[_D1], plant[_N_R], plant[_A_MAX], plant[_TA]
    m_r, floor, tol = plant[_M_R], plant[_H_FLOOR], plant[_H_TOL]
    new_heads = heads.copy()
    new_flows = flows.copy()
    eps_t = 1e-9 * dt
    for k in range(n_steps):
        t = k * dt
        t_next = (k + 1) * dt
        x = out_speed[k] / n_r - 1.0
        y = out_stroke[k]
        # 1. control
        if mode == 0:
            x_ref = piecewise_constant(ref_times, ref_values, t + eps_t, 0.0)
            command = governor_step(gov_params, gov_state, x, x_ref, y, dt)
            y_next = servo_step(gov_params, command, y)
        else:
            y_next = piecewise_linear(law_times, law_strokes, t_next + eps_t)
        # 2. rotor
        load = piecewise_constant(load_times, load_values, t + eps_t, load0)
        reg = piecewise_constant(load_times, reg_values, t + eps_t, reg0)
        x_next = rotor_step(x, out_torque[k] / m_r, load, reg, ta, dt)
        speed = n_r * (1.0 + x_next)
        opening = y_next * a_max
        # 3. penstock relation H = C_L + k Q
        if is_moc:
            c_l, slope = moc_turbine_relation(heads, flows, impedance, friction)
        else:
            c_l, slope = iir_turbine_relation(iir_coef, iir_hist, plant[_H_ST], plant[_K_F], plant[_H_R],
                                              plant[_Q_R], plant[_Q0])
        # 4. turbine boundary (shut vanes: a closed valve, no iteration)
        if y_next <= plant[_Y_CLOSED]:
            head, flow, iters, residual, status = c_l, 0.0, 0, 0.0, 0
            if head < floor:
                status = 2
        else:
            head, flow, iters, residual, status = solver(kernel, params, c_l, slope, speed, opening, out_head[k],
                                                         d1, floor, tol, max_iterations, relaxation)
        if status != 0:
            diag[0] = t_next
            diag[1] = speed
            diag[2] = opening
            diag[3] = out_head[k]
            diag[4] = c_l
            diag[5] = slope
            diag[6] = residual
            return status, k + 1
        m11 = kernel(params, speed * d1 / math.sqrt(head), opening)[3]
        # 5. penstock update
        if is_moc:
            moc_step(heads, flows, impedance, friction, plant[_H_ST], head, flow, new_heads, new_flows)
            heads, new_heads = new_heads, heads
            flows, new_flows = new_flows, flows
        else:
            iir_step(iir_coef, iir_hist, flow, plant[_Q0], plant[_Q_R])
        out_speed[k + 1] = speed
        out_head[k + 1] = head
        out_flow[k + 1] = flow
        out_stroke[k + 1] = y_next
        out_torque[k + 1] = m11 * d1 ** 3 * head
        out_iter[k + 1] = iters
    return 0, n_steps + 1


def initial_state(plant: PlantConfig, characteristics=None) -> SteadyState:
    """The verified steady state a run of ``plant`` starts from (see :mod:`simulate.steady`).

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml", {"turbine.characteristics": "ideal"})
    >>> s = initial_state(plant)
    >>> round(s.power_mw, 9), s.speed_rpm, max(abs(v) for v in s.residuals.values()) < 1e-9
    (225.0, 200.0, True)
    """
    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    kernel, params, _ = scalar_kernel(chars)
    return steady_state(kernel, params, turbine=plant.turbine, static_head_m=plant.penstock.static_head_m,
                        friction_s2_m5=plant.penstock.friction_coefficient_s2_m5,
                        stroke_min=plant.governor.stroke_min, stroke_max=plant.governor.stroke_max,
                        **initial_target(plant.scenario))


def run_simulation(plant: PlantConfig, characteristics=None, *, jit: bool = True,
                   raise_on_failure: bool = True) -> SimulationResult:
    """Simulate ``plant`` (its scenario) and return the :class:`SimulationResult`.

    Parameters
    ----------
    plant : PlantConfig
    characteristics : object implementing :class:`hillchart.characteristics.Characteristics`, optional
        Overrides ``plant.turbine.characteristics`` (any object with q11, m11 and their gradients).
    jit : bool
        Run the compiled loop when the characteristics offer a numba kernel; False runs the same source as
        plain Python (slow; for checks).
    raise_on_failure : bool
        A pressure-loop failure raises :class:`NumericalError` (default) or, when False, returns the series up to
        the failure with ``success=False``.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from hillchart.characteristics import IdealTurbine
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml",
    ...                    {"turbine.characteristics": "ideal", "scenario.t_end_s": 5.0})
    >>> result = run_simulation(plant)
    >>> result.success, round(result.summary()["max_speed_rise"], 2) > 0
    (True, True)
    """
    dt = plant.time_step_s  # Courant check before anything heavier
    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    kernel, params, jitted = scalar_kernel(chars)
    turbine, pen, gen = plant.turbine, plant.penstock, plant.generator
    n_steps = int(round(plant.scenario.t_end_s / dt))
    if n_steps < 1:
        raise InputError(f"scenario.t_end_s = {plant.scenario.t_end_s!r} is shorter than one step "
                         f"(dt = {dt:.6g} s)")
    steady = initial_state(plant, chars)

    tw = pen.water_time_s(turbine.rated_flow_m3_s, turbine.rated_head_m)
    friction = pen.friction_coefficient_s2_m5
    is_moc = pen.model == "moc"
    if is_moc:
        grid = build_moc_grid(pen, dt)
        heads, flows = moc_steady_state(grid, pen.static_head_m, steady.flow_m3_s)
        impedance, reach_friction = grid.impedance_s_m2, grid.friction_s2_m5
        model_meta = {"moc_reaches": int(sum(grid.reaches_per_segment)),
                      "moc_max_wave_speed_adjustment": grid.max_wave_speed_adjustment}
    else:
        heads = flows = impedance = reach_friction = np.zeros(2)
        model_meta = {}
    iir_coef = (iir_coefficients(pen.model, water_time_s=tw, travel_time_s=pen.travel_time_s, step_s=dt,
                                 lumped_alpha=pen.lumped_alpha, zdomain_feedback=pen.zdomain_feedback)
                if not is_moc else np.zeros(5))
    iir_hist = np.array([0.0, 0.0, 0.0, 0.0, steady.flow_m3_s])

    plant_vec = np.zeros(13)
    plant_vec[_Y_CLOSED] = CLOSED_STROKE
    plant_vec[[_D1, _N_R, _H_R, _Q_R, _M_R, _A_MAX, _TA]] = (
        turbine.runner_diameter_m, turbine.rated_speed_rpm, turbine.rated_head_m, turbine.rated_flow_m3_s,
        turbine.rated_torque_nm, turbine.opening_max, gen.inertia_time_s)
    plant_vec[[_H_FLOOR, _H_TOL, _H_ST, _K_F, _Q0]] = (
        HEAD_FLOOR_FRACTION * turbine.rated_head_m, plant.solver.tolerance * turbine.rated_head_m,
        pen.static_head_m, friction, steady.flow_m3_s)

    load0 = steady.torque_nm / turbine.rated_torque_nm
    sched = build_schedules(plant, steady.stroke, load0)
    gov_params = governor_parameters(plant.governor, steady.stroke, dt)
    gov_state = np.zeros(3)

    rows = n_steps + 1
    out = {name: np.zeros(rows) for name in ("speed", "head", "flow", "stroke", "torque")}
    out_iter = np.zeros(rows, dtype=np.int64)
    out["speed"][0], out["head"][0], out["flow"][0] = steady.speed_rpm, steady.head_m, steady.flow_m3_s
    out["stroke"][0], out["torque"][0] = steady.stroke, steady.torque_nm
    diag = np.zeros(8)

    solver = SOLVERS[plant.solver.pressure_loop]
    if jit and jitted:
        loop = _time_loop
    else:
        loop, solver = _time_loop.py_func, solver.py_func
        kernel = getattr(kernel, "py_func", kernel)
    wall = _time.perf_counter()
    status, n_rows = loop(kernel, params, solver, n_steps, dt, plant_vec, is_moc, heads.copy(), flows.copy(),
                          impedance, reach_friction, iir_coef, iir_hist, sched.mode, gov_params, gov_state,
                          sched.law_times_s, sched.law_strokes, sched.ref_times_s, sched.ref_values,
                          sched.load_times_s, sched.load_values, sched.self_regulation_values, sched.initial_load,
                          sched.initial_self_regulation, plant.solver.max_iterations, plant.solver.relaxation,
                          out["speed"], out["head"], out["flow"], out["stroke"], out["torque"], out_iter, diag)
    wall = _time.perf_counter() - wall

    message = "ok"
    if status != 0:
        message = (f"pressure loop '{plant.solver.pressure_loop}' failed ({STATUS_TEXT[int(status)]}) at t = "
                   f"{diag[0]:.6g} s (step {n_rows}): speed {diag[1]:.6g} r/min, opening {diag[2]:.6g} (chart "
                   f"units), head guess {diag[3]:.6g} m, penstock relation H = {diag[4]:.6g} + ({diag[5]:.6g}) Q, "
                   f"last head residual {diag[6]:.3g} m (tolerance {plant_vec[_H_TOL]:.3g} m, "
                   f"{plant.solver.max_iterations} iterations, relaxation {plant.solver.relaxation})")
        if raise_on_failure:
            raise NumericalError(message)
    time_s = np.arange(n_rows) * dt
    speed = out["speed"][:n_rows]
    torque = out["torque"][:n_rows]
    ref_end = float(piecewise_constant(sched.ref_times_s, sched.ref_values, time_s[-1] + 1e-9 * dt, 0.0)) \
        if sched.mode == 0 else 0.0
    meta = {"scenario": plant.scenario.kind, "penstock_model": pen.model,
            "pressure_loop": plant.solver.pressure_loop, "dt_s": dt, "water_time_s": tw,
            "travel_time_s": pen.travel_time_s, "compiled": bool(jit and jitted),
            "steady_state_max_residual": max(abs(v) for v in steady.residuals.values())}
    meta.update(model_meta)
    return SimulationResult(
        time_s=time_s, speed_rpm=speed, head_m=out["head"][:n_rows], flow_m3_s=out["flow"][:n_rows],
        opening=out["stroke"][:n_rows], opening_chart=out["stroke"][:n_rows] * turbine.opening_max,
        torque_nm=torque, power_mw=torque * speed * (2.0 * math.pi / 60.0) * 1e-6, iterations=out_iter[:n_rows],
        speed_reference_rpm=turbine.rated_speed_rpm * (1.0 + ref_end), rated_speed_rpm=turbine.rated_speed_rpm,
        success=status == 0, message=message, meta=meta, wall_time_s=wall)
