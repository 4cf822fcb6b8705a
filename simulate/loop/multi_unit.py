"""The run of a plant with several units (``[[units]]``): the steady state of all units on the shared conduit, the
components of every unit from the registries, the loop of :mod:`simulate.loop.manifold`, the result record.

:func:`simulate.loop.engine.run_simulation` hands a plant with ``[[units]]`` to :func:`run_units`; a plant without
keeps the single-unit loop.
"""

from __future__ import annotations

import math

import numpy as np

from hillchart.errors import InputError, NumericalError
from simulate.components.turbine.boundary import STATUS_TEXT, turbine_parameters, turbine_state
from simulate.components.turbine.component import load_characteristics
from simulate.config import PlantConfig
from simulate.loop.manifold import MANIFOLD_SERIES, UNIT_SERIES
from simulate.loop.steady import ManifoldSteadyState, manifold_steady_state
from simulate.results.result import SimulationResult, unit_figures, worst_over_units
from simulate.scenarios import GOVERNOR, build_schedules, initial_target, steady_schedules


def unit_characteristics(plant: PlantConfig, characteristics=None) -> list:
    """The characteristics of every unit (``characteristics`` for all when given, else each unit's
    ``turbine.characteristics``; units with the same turbine section share one object)."""
    from simulate.components.turbine.double_regulated import is_three_input

    if characteristics is not None:
        out = [characteristics] * len(plant.units)
    else:
        loaded: dict = {}
        out = []
        for unit in plant.units:
            if unit.turbine not in loaded:
                loaded[unit.turbine] = load_characteristics(unit.turbine, plant.base_dir)
            out.append(loaded[unit.turbine])
    for unit, chars in zip(plant.units, out):
        if is_three_input(chars):
            raise InputError(f"unit {unit.name!r}: turbine.characteristics = {unit.turbine.characteristics!r} has a "
                             f"blade angle (three inputs, a double-regulated turbine); a plant with [[units]] runs "
                             f"single-regulated units with two-input characteristics (\"ideal\", \"synthetic\" or "
                             f"nets with inputs n11, opening): simulate a double-regulated unit as a plant of one "
                             f"unit (leave [[units]] out)")
    return out


def units_initial_state(plant: PlantConfig, characteristics: list) -> ManifoldSteadyState:
    """The verified steady state of every unit with the common conduit's loss of the summed flow (see
    :func:`simulate.loop.steady.manifold_steady_state`)."""
    from hillchart.characteristics import scalar_kernel
    from simulate.loop.common import upstream_friction_s2_m5

    units = []
    for unit, chars in zip(plant.units, characteristics):
        kernel, params, _ = scalar_kernel(chars)
        view = plant.unit_plant(unit)
        units.append(dict(name=unit.name, kernel=kernel, params=params, turbine=unit.turbine,
                          branch_friction_s2_m5=view.penstock.friction_coefficient_s2_m5,
                          stroke_min=unit.governor.stroke_min, stroke_max=unit.governor.stroke_max,
                          **initial_target(view.scenario)))
    friction = plant.penstock.friction_coefficient_s2_m5 + upstream_friction_s2_m5(plant)
    try:
        return manifold_steady_state(units, static_head_m=plant.penstock.static_head_m, friction_s2_m5=friction)
    except InputError as exc:
        raise InputError(f"{exc} (the scenario's initial point is each unit's; set units.initial_power_mw or "
                         f"units.initial_opening of a unit for its own)") from None


def unit_schedules(plant: PlantConfig, steady: ManifoldSteadyState) -> list:
    """Each unit's schedules: the scenario's for the units of ``scenario.units`` (default all), an undisturbed unit
    on its load under its governor for the others."""
    out = []
    events = set(plant.event_units)
    for unit, st in zip(plant.units, steady.units):
        view = plant.unit_plant(unit)
        load = st.torque_nm / unit.turbine.rated_torque_nm
        out.append(build_schedules(view, st.stroke, load) if unit.name in events
                   else steady_schedules(view, st.stroke, load))
    return out


def run_units(plant: PlantConfig, characteristics=None, *, jit: bool = True, raise_on_failure: bool = True,
              progress=None) -> SimulationResult:
    """Simulate a plant with several units (its scenario); the arguments are those of
    :func:`simulate.loop.engine.run_simulation`.

    The result's plant-level series (``speed_rpm``, ``head_m``, ...) are those of the first unit the event applies
    to; ``result.units`` holds every unit's, ``signals`` the manifold head and the common flow, and the summary the
    worst figures over the units (see :func:`simulate.results.result.worst_over_units`) and ``"units"``.
    """
    from simulate.components.registry import CONTROLS, PENSTOCKS, SHAFTS, UPSTREAM, upstream_section
    from simulate.components.turbine.evaluation import compile_characteristics
    from simulate.loop import guards
    from simulate.loop.domain import extrapolation_record, extrapolation_warnings, plant_domain, units_record
    from simulate.loop.common import CLOSED_STROKE, HEAD_FLOOR_FRACTION, _failure_advice, run_in_chunks, step_count
    from simulate.loop.manifold import assemble_units
    from simulate.components.signals import check_provided, initial_signals
    from simulate.loop.timestep import plan_step

    dt = plant.time_step_s
    views = [plant.unit_plant(unit) for unit in plant.units]
    chars = unit_characteristics(plant, characteristics)
    compiled_once: dict = {}  # one compiled kernel per characteristics object (units may share one)
    for c in chars:
        if id(c) not in compiled_once:
            compiled_once[id(c)] = compile_characteristics(c)
    compiled_chars = [compiled_once[id(c)] for c in chars]
    first = compiled_chars[0]
    for unit, cc in zip(plant.units[1:], compiled_chars[1:]):
        if type(cc) is not type(first) or cc.kernel is not first.kernel:
            raise InputError(f"unit {unit.name!r}: turbine.characteristics = {unit.turbine.characteristics!r} is "
                             f"another kind of characteristics than those of unit {plant.units[0].name!r} "
                             f"({plant.units[0].turbine.characteristics!r}); the units of one plant share one kind "
                             f"(ideal, synthetic or nets, each unit with its own rated values or nets file)")
    domains = [plant_domain(view, c) for view, c in zip(views, chars)]
    steady = units_initial_state(plant, chars)
    schedules = unit_schedules(plant, steady)
    plans = [plan_step(view, sched, grid_step_s=dt) for view, sched in zip(views, schedules)]
    n_sub = max(p.substeps for p in plans)
    n_steps = step_count(plant.scenario.t_end_s, dt)
    stride = guards.output_stride(plant, dt)
    guards.check_run_size(plant, dt, n_steps, stride, n_sub)
    warnings = []
    for unit, view, st, domain, plan in zip(plant.units, views, steady.units, domains, plans):
        try:
            guards.check_initial_state(view, st, domain)
        except InputError as exc:
            raise InputError(f"unit {unit.name!r}: {exc}") from None
        warnings += [f"unit {unit.name}: {w}" for w in guards.plausibility_warnings(view) + list(plan.warnings)]
    warnings = list(dict.fromkeys(warnings))

    sub_dt = dt / n_sub
    upstream = UPSTREAM.builder(upstream_section(plant)[0])(plant, steady, dt)
    head0 = upstream.hooks.initial_head_m
    head0 = plant.penstock.static_head_m if head0 is None else head0
    common = {"upstream": upstream, "penstock": PENSTOCKS.builder(plant.penstock.model)(plant, steady, dt, head0)}
    unit_parts, unit_args = [], []
    for unit, view, st, sched, cc in zip(plant.units, views, steady.units, schedules, compiled_chars):
        try:
            branch = PENSTOCKS.builder("moc")(view, st, dt, steady.head_m)
        except InputError as exc:
            raise InputError(f"{str(exc).replace('segment ', 'units.branch segment ', 1)} (unit {unit.name!r})") \
                from None
        try:
            parts = {"branch": branch,
                     "control": CONTROLS.builder("governor" if sched.mode == GOVERNOR else "prescribed")(
                         view, st, sub_dt, sched),
                     "shaft": SHAFTS.builder("swing")(view, st, sub_dt, sched)}
        except InputError as exc:
            text = str(exc).replace("solver.dt_s (or penstock.reaches)", "penstock.reaches")  # dt is the grid's
            raise InputError(f"unit {unit.name!r}: {text}") from None
        for kind in ("control", "shaft"):
            if parts[kind].signals:
                raise InputError(f"unit {unit.name!r}: its {kind} component {parts[kind].name!r} records signals of "
                                 f"its own, which a plant with [[units]] does not store")
        tp = turbine_parameters(unit.turbine, plant.solver,
                                head_floor_m=HEAD_FLOOR_FRACTION * unit.turbine.rated_head_m,
                                closed_stroke=CLOSED_STROKE, control_scales=[unit.turbine.opening_max])
        ts = turbine_state(st.head_m, st.flow_m3_s, st.torque_nm, 1)
        check_provided(parts["control"], parts["shaft"], f"unit {unit.name!r}: ")
        unit_parts.append(parts)
        unit_args.append((tp, ts, cc.params, parts["branch"].params, parts["branch"].state,
                          parts["control"].params, parts["control"].state, parts["shaft"].params,
                          parts["shaft"].state, initial_signals(parts["control"], parts["shaft"], st.head_m,
                                                                st.torque_nm)))

    n_units = len(plant.units)
    rows = n_steps // stride + 1
    out_units = np.zeros((rows, n_units, len(UNIT_SERIES)))
    out_iter = np.zeros((rows, n_units), dtype=np.int64)
    out_manifold = np.zeros((rows, len(MANIFOLD_SERIES) + 2 * n_units))
    signal_names = list(upstream.signals)
    out_signals = np.zeros((rows, len(signal_names)))
    if signal_names:
        out_signals[0] = upstream.hooks.initial_signals
    for i, st in enumerate(steady.units):
        out_units[0, i] = (st.speed_rpm, st.head_m, st.flow_m3_s, st.torque_nm, st.stroke)
        out_manifold[0, len(MANIFOLD_SERIES) + 2 * i:len(MANIFOLD_SERIES) + 2 * i + 2] = (st.flow_m3_s, steady.head_m)
    out_manifold[0, :len(MANIFOLD_SERIES)] = (steady.head_m, steady.flow_m3_s, steady.flow_m3_s, steady.head_m)
    pen_part = common["penstock"]
    nodes = np.zeros(pen_part.n_nodes)
    node_heads = pen_part.functions["node_heads"]
    getattr(node_heads, "py_func", node_heads)(pen_part.params, pen_part.state, head0, steady.head_m, nodes)
    env_max, env_min = nodes.copy(), nodes.copy()
    diag = np.zeros(9)
    from simulate.components.hydraulic.junction import manifold_state

    compiled = bool(jit and first.jitted)
    loop = assemble_units(common, unit_parts, first, plant.solver.pressure_loop, compiled=compiled)
    args = (upstream.params, upstream.state, pen_part.params, pen_part.state, tuple(unit_args),
            manifold_state(n_units), out_units, out_iter, out_manifold, out_signals, env_max, env_min, diag)
    status, k_done, wall = run_in_chunks(loop, args, n_steps, dt, n_sub, stride, progress)

    message = "ok"
    all_time = np.arange(rows) * (dt * stride)
    if status == 0:  # the upstream part may find the run invalid afterwards (a surge tank running dry)
        problem = upstream.hooks.error_for(all_time, {name: out_signals[:, j] for j, name in enumerate(signal_names)})
        if problem:
            if raise_on_failure:
                raise NumericalError(problem)
            message, status = problem, -1
    if status > 0:
        failed_step = int(k_done)
        n_rows = failed_step // stride + 1
        unit = plant.units[int(diag[8])]
        message = (f"unit {unit.name!r}: pressure loop '{plant.solver.pressure_loop}' failed "
                   f"({STATUS_TEXT[int(status)]}) at t = {diag[0]:.6g} s (step {failed_step + 1}): speed "
                   f"{diag[1]:.6g} r/min, opening {diag[2]:.6g} (chart units), head guess {diag[3]:.6g} m, branch "
                   f"relation H = {diag[4]:.6g} + ({diag[5]:.6g}) Q, last head residual {diag[6]:.3g} m "
                   f"({plant.solver.max_iterations} iterations, relaxation {plant.solver.relaxation}"
                   + _failure_advice(int(status), plant.solver, diag[4], unit.turbine.rated_head_m))
        if raise_on_failure:
            raise NumericalError(message)
    else:
        n_rows = rows
    time_s = all_time[:n_rows]

    units = {}
    event_units = plant.event_units
    for i, (unit, sched, domain) in enumerate(zip(plant.units, schedules, domains)):
        speed, head, flow, torque, stroke = (out_units[:n_rows, i, j].copy() for j in range(len(UNIT_SERIES)))
        ref_end = 0.0
        if sched.mode == GOVERNOR:
            from simulate.components.schedules import piecewise_constant

            ref_end = float(getattr(piecewise_constant, "py_func", piecewise_constant)(
                sched.ref_times_s, sched.ref_values, time_s[-1] + 1e-9 * dt, 0.0))
        t = unit.turbine
        n11 = speed * t.runner_diameter_m / np.sqrt(np.maximum(head, HEAD_FLOOR_FRACTION * t.rated_head_m))
        record = extrapolation_record(domain, time_s, n11, stroke * t.opening_max, stroke,
                                      figure_times={"max_speed_rise": float(time_s[int(np.argmax(speed))]),
                                                    "max_head_rise": float(time_s[int(np.argmax(head))])})
        warnings += [f"unit {unit.name}: {w}" for w in extrapolation_warnings(record)]
        units[unit.name] = {"speed_rpm": speed, "head_m": head, "flow_m3_s": flow, "opening": stroke,
                            "opening_chart": stroke * t.opening_max, "torque_nm": torque,
                            "power_mw": torque * speed * (2.0 * math.pi / 60.0) * 1e-6,
                            "iterations": out_iter[:n_rows, i].copy(),
                            "speed_reference_rpm": t.rated_speed_rpm * (1.0 + ref_end), "extrapolation": record}
    lead = event_units[0] if event_units else plant.units[0].name
    lead_index = [u.name for u in plant.units].index(lead)
    signals = {name: out_signals[:n_rows, j].copy() for j, name in enumerate(signal_names)}
    signals["manifold_head_m"] = out_manifold[:n_rows, 0].copy()
    signals["manifold_flow_m3_s"] = out_manifold[:n_rows, 1].copy()
    junction = {name: out_manifold[:n_rows, j].copy() for j, name in enumerate(MANIFOLD_SERIES)}
    for i, unit in enumerate(plant.units):
        junction[f"{unit.name}.branch_inlet_flow_m3_s"] = out_manifold[:n_rows, len(MANIFOLD_SERIES) + 2 * i].copy()
        junction[f"{unit.name}.branch_inlet_head_m"] = out_manifold[:n_rows, len(MANIFOLD_SERIES) + 2 * i + 1].copy()

    pen = plant.penstock
    fallback_steps = int(diag[7])
    if fallback_steps > 0:
        warnings.append(f"the pressure loop '{plant.solver.pressure_loop}' did not converge at {fallback_steps} unit "
                        f"steps of {n_steps} steps and its fallback solved them: set solver.pressure_loop = "
                        f"\"newton\" or a smaller solver.relaxation for a faster run")
    meta = {"scenario": plant.scenario.kind, "penstock_model": pen.model,
            "pressure_loop": plant.solver.pressure_loop, "dt_s": dt, "substeps": n_sub, "dt_chosen": False,
            "dt_limited_by": "the MOC grid ((shortest travel time of the conduit and the branches) / "
                             "penstock.reaches)",
            "pressure_loop_fallback_steps": fallback_steps, "travel_time_s": pen.travel_time_s,
            "compiled": compiled, "unit_names": [u.name for u in plant.units], "event_units": list(event_units),
            "series_unit": lead, "initial_manifold_head_m": steady.head_m,
            "steady_state_max_residual": max(abs(v) for st in steady.units for v in st.residuals.values())}
    if stride != 1:
        meta["output_dt_s"] = dt * stride
    meta.update(upstream.hooks.summary)
    component_figures = upstream.hooks.figures_after(time_s, signals)
    meta.update(component_figures)
    meta.update({f"conduit_{k}": v for k, v in pen_part.hooks.summary.items()})
    for parts in unit_parts:  # e.g. the discrete servo's settings (the branches' grid is in conduit_* and below)
        meta.update(parts["control"].hooks.summary)
        meta.update(parts["shaft"].hooks.summary)
    warnings += upstream.hooks.warnings_for(signals)
    # the plant-level figures are the worst over the units (SimulationResult.summary): so is their record
    worst = worst_over_units({u.name: unit_figures(time_s, units[u.name], u.turbine.rated_speed_rpm)
                              for u in plant.units})
    meta["extrapolation"] = units_record({name: series["extrapolation"] for name, series in units.items()},
                                         {figure: worst[f"{figure}_unit"] for figure in ("max_speed_rise",
                                                                                         "max_head_rise")
                                          if f"{figure}_unit" in worst}, lead)
    meta["warnings"] = warnings
    lead_series = units[lead]
    return SimulationResult(
        time_s=time_s, speed_rpm=lead_series["speed_rpm"], head_m=lead_series["head_m"],
        flow_m3_s=lead_series["flow_m3_s"], opening=lead_series["opening"],
        opening_chart=lead_series["opening_chart"], torque_nm=lead_series["torque_nm"],
        power_mw=lead_series["power_mw"], iterations=lead_series["iterations"],
        speed_reference_rpm=lead_series["speed_reference_rpm"],
        rated_speed_rpm=plant.units[lead_index].turbine.rated_speed_rpm, success=status == 0, message=message,
        meta=meta, wall_time_s=wall, signals=signals, envelope_x_m=np.asarray(pen_part.node_x_m, float),
        envelope_max_m=env_max, envelope_min_m=env_min, steady=steady, plant=plant, characteristics=chars[lead_index],
        units=units, junction=junction, component_figures=component_figures)
