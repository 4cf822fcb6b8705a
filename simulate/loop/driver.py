"""The one run driver: the work before and after the time loop, written once for a list of units.

A plant without ``[[units]]`` is a plant with one unit whose conduit is the plant's penstock and that has no
junction; a plant with ``[[units]]`` has one unit per entry, each with its branch as its conduit, on the plant's
penstock as the common conduit that branches at a manifold. Per unit the driver prepares the characteristics (as
the unit uses them: three-input ones through the combinator), the trusted domain, the verified steady state, the
schedules, the time-step plan and the initial-point guards, and builds the unit's conduit, downstream part, control
and shaft from the registries; the loop is the one template of :mod:`simulate.loop.generator`. After the loop: the
components' checks, the failure message, the meta, the extrapolation record, the warnings and the
:class:`~simulate.results.result.SimulationResult`.

:func:`simulate.loop.engine.run_simulation` and :func:`simulate.loop.multi_unit.run_units` call :func:`run_plant`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hillchart.errors import InputError, NumericalError
from simulate.components.turbine.boundary import FALLBACK_DAMPING
from simulate.components.turbine.component import BoundaryInputs, build_turbine_part, plant_turbine
from simulate.components.turbine.kinds import kind_of
from simulate.config import PlantConfig
from simulate.loop.common import CLOSED_STROKE, HEAD_FLOOR_FRACTION, run_in_chunks, step_count
from simulate.loop.generator import MANIFOLD_SERIES, UNIT_SERIES, assemble, signal_columns
from simulate.loop.prepare import (_memo, initial_state, plant_characteristics, plant_schedules, unit_schedules,
                                   unit_turbines, units_initial_state)
from simulate.results.result import SimulationResult, largest_speed_index, unit_figures, worst_over_units
from simulate.scenarios import GOVERNOR


@dataclass
class _Unit:
    """What the driver holds for one unit: its name (None for a plant of one unit), its single-unit view of the
    plant, characteristics (as the unit uses them) and their compiled form, trusted domain, the characteristics'
    kind (its registry word; None for the caller's object), steady state, schedules, time-step plan and, once built,
    its parts (``conduit``, ``downstream``, ``control``, ``shaft``, ``turbine``)."""

    name: str | None
    view: PlantConfig
    chars: object
    compiled: object
    domain: object
    kind: str | None = None
    steady: object = None
    schedules: object = None
    plan: object = None
    parts: dict = field(default_factory=dict)

    def prefix(self, sep: str = ": ") -> str:
        """``"unit 'U1': "`` before a message of a unit of a plant with several units; nothing for a plant of one."""
        return "" if self.name is None else f"unit {self.name!r}{sep}"

    def note(self, text: str) -> str:
        """A warning of this unit (``"unit U1: ..."`` with several units)."""
        return text if self.name is None else f"unit {self.name}: {text}"


def _characteristics(plant: PlantConfig, characteristics) -> list:
    """The units (name, view, characteristics, compiled characteristics, domain, kind) of ``plant``."""
    from simulate.components.turbine.evaluation import compile_characteristics
    from simulate.loop.domain import plant_domain

    if plant.units:
        named = [(unit.name, plant.unit_plant(unit)) for unit in plant.units]
        chars, kinds = zip(*unit_turbines(plant, characteristics))
    else:
        named = [(None, plant)]
        turbine = plant_turbine(plant, characteristics)
        chars, kinds = [plant_characteristics(plant, turbine.characteristics)], [turbine.kind]
    units = []
    for (name, view), c, kind in zip(named, chars, kinds):
        compiled = _memo(c, ("compiled",), lambda c=c: compile_characteristics(c))
        domain = _memo(c, ("domain", view.turbine.characteristics, str(plant.base_dir)),
                       lambda view=view, c=c: plant_domain(view, c))
        units.append(_Unit(name, view, c, compiled, domain, kind))
    first = units[0]
    for unit in units[1:]:  # the generated loop binds one kernel for every unit
        if type(unit.compiled) is not type(first.compiled) or unit.compiled.kernel is not first.compiled.kernel:
            raise InputError(f"unit {unit.name!r}: turbine.characteristics = {unit.view.turbine.characteristics!r} "
                             f"is another kind of characteristics than those of unit {first.name!r} "
                             f"({first.view.turbine.characteristics!r}); the units of one plant share one kind "
                             f"(ideal, synthetic or nets, each unit with its own rated values or nets file)")
    return units


def _step_failure(turbine, status: int, diag, conduit: str) -> tuple[str, str]:
    """``(what, details)`` of a turbine boundary ``turbine`` (a unit's part) whose step returned ``status`` > 0: its
    own words (:attr:`simulate.components.registry.PartHooks.step_failure`), else the status and ``diag[1:7]``."""
    if turbine.hooks.step_failure is not None:
        return turbine.hooks.step_failure(status, diag, conduit)
    return (f"turbine boundary {turbine.name!r} failed (status {status})",
            f"what its step left in diag[1:7]: {', '.join(f'{v:.6g}' for v in diag[1:7])}")


def _unit_parts(unit: _Unit, conduit, dt_s: float, sub_dt_s: float) -> dict:
    """The unit's parts from the registries: its ``conduit`` (built by the caller), its downstream part on the
    step ``dt_s``, its control and shaft on the sub-step ``sub_dt_s``."""
    from simulate.components.registry import CONTROLS, DOWNSTREAM, SHAFTS, control_name, downstream_section, \
        shaft_section

    view, steady, schedules = unit.view, unit.steady, unit.schedules
    try:
        shaft = SHAFTS.builder(shaft_section(view)[0])(view, steady, sub_dt_s, schedules)
        downstream = DOWNSTREAM.builder(downstream_section(view)[0])(view, steady, dt_s)
        name = control_name(view, schedules)
        extra = {"characteristics": unit.chars} if name.endswith("_blades") else {}
        control = CONTROLS.builder(name)(view, steady, sub_dt_s, schedules, **extra)
    except InputError as exc:
        if unit.name is None:
            raise
        text = str(exc).replace("solver.dt_s (or penstock.reaches)", "penstock.reaches")  # dt is the grid's
        raise InputError(f"{unit.prefix()}{text}") from None
    return {"conduit": conduit, "shaft": shaft, "downstream": downstream, "control": control}


def run_plant(plant: PlantConfig, characteristics=None, *, jit: bool = True, raise_on_failure: bool = True,
              progress=None) -> SimulationResult:
    """Simulate ``plant`` (its scenario), of one unit or of several; the arguments are those of
    :func:`simulate.loop.engine.run_simulation`."""
    from simulate.components.hydraulic.junction import manifold_state
    from simulate.components.registry import PENSTOCKS, UPSTREAM, upstream_section
    from simulate.components.signals import check_provided, initial_signals
    from simulate.loop import guards
    from simulate.loop.timestep import plan_step

    several = bool(plant.units)
    grid_dt = plant.time_step_s  # the Courant check of the grid before anything heavier
    units = _characteristics(plant, characteristics)
    if several:
        steady = units_initial_state(plant, [u.chars for u in units])
        for unit, st, sched in zip(units, steady.units, unit_schedules(plant, steady)):
            unit.steady, unit.schedules = st, sched
            unit.plan = plan_step(unit.view, sched, grid_step_s=grid_dt)
        dt, n_sub = grid_dt, max(u.plan.substeps for u in units)
    else:
        unit = units[0]
        steady = unit.steady = initial_state(plant, unit.chars)
        unit.schedules = plant_schedules(plant, steady)
        unit.plan = plan_step(plant, unit.schedules)  # the step from the components' time scales
        dt, n_sub = unit.plan.dt_s, unit.plan.substeps
    n_steps = step_count(plant.scenario.t_end_s, dt)
    stride = guards.output_stride(plant, dt)
    guards.check_run_size(plant, dt, n_steps, stride, n_sub)
    warnings = []
    for unit in units:
        domain_key = ("domain", unit.view.turbine.characteristics, str(plant.base_dir))
        try:
            guards.check_initial_state(unit.view, unit.steady, unit.domain, remember=lambda key, compute, u=unit,
                                       d=domain_key: _memo(u.chars, key + d, compute))
        except InputError as exc:
            if unit.name is None:
                raise
            raise InputError(f"{unit.prefix()}{exc}") from None
        found = guards.plausibility_warnings(unit.view) + list(unit.plan.warnings)
        found += guards.characteristics_warnings(unit.view.turbine, unit.chars)
        training = getattr(unit.chars, "training", None)
        if isinstance(training, dict) and training.get("kind") == "on-cam":  # nets of a chart without vane angles
            from hillchart.fccm.on_cam import ON_CAM_WARNING

            found.append(ON_CAM_WARNING)
        if getattr(unit.chars, "cam_warning", None):  # the nets' cam and their fitted model's disagree
            found.append(unit.chars.cam_warning)
        warnings += [unit.note(w) for w in found]
    warnings = list(dict.fromkeys(warnings))

    # the parts: the upstream part, the common conduit (several units) and every unit's
    sub_dt = dt / n_sub
    upstream = UPSTREAM.builder(upstream_section(plant)[0])(plant, steady, dt)
    head0 = upstream.hooks.initial_head_m
    head0 = plant.penstock.static_head_m if head0 is None else head0
    penstock = PENSTOCKS.builder(plant.penstock.model)(plant, steady, dt, head0)
    common = {"upstream": upstream}
    if several:
        common["penstock"] = penstock
    unit_args = []
    for unit in units:
        conduit = penstock
        if several:
            try:  # the branch, from the manifold head
                conduit = PENSTOCKS.builder(unit.view.penstock.model)(unit.view, unit.steady, dt, steady.head_m)
            except InputError as exc:
                raise InputError(f"{str(exc).replace('segment ', 'units.branch segment ', 1)} (unit "
                                 f"{unit.name!r})") from None
        unit.parts = parts = _unit_parts(unit, conduit, dt, sub_dt)
        turbine, st = unit.view.turbine, unit.steady
        parts["turbine"] = build_turbine_part(unit.kind, BoundaryInputs(
            turbine=turbine, solver=plant.solver, characteristics=unit.chars, compiled=unit.compiled, steady=st,
            n_controls=parts["control"].hooks.n_controls, head_floor_m=HEAD_FLOOR_FRACTION * turbine.rated_head_m,
            closed_stroke=CLOSED_STROKE))
        check_provided(parts["control"], parts["shaft"], unit.prefix(), upstream=upstream)
        unit_args.append((parts["turbine"].params, parts["turbine"].state, conduit.params, conduit.state,
                          parts["downstream"].params,
                          parts["downstream"].state, parts["control"].params, parts["control"].state,
                          parts["shaft"].params, parts["shaft"].state,
                          initial_signals(parts["control"], parts["shaft"], st.head_m, st.torque_nm, upstream)))
    unit_parts = [u.parts for u in units]

    # the output arrays, row 0 from the steady state
    n_units = len(units)
    rows = n_steps // stride + 1
    widest = max(p["control"].hooks.n_controls for p in unit_parts)
    out_units = np.zeros((rows, n_units, len(UNIT_SERIES) + widest))
    out_iter = np.zeros((rows, n_units), dtype=np.int64)
    columns = signal_columns(common, unit_parts)
    signal_names, owners = [], []
    for owner, part in columns:
        signal_names += [name if owner is None or not several else f"{units[owner].name}.{name}"
                         for name in part.signals]
        owners += [owner] * len(part.signals)
    out_signals = np.zeros((rows, len(signal_names)))
    column = 0
    for owner, part in columns:
        out_signals[0, column:column + len(part.signals)] = part.hooks.initial_signals
        column += len(part.signals)
    for i, (unit, parts) in enumerate(zip(units, unit_parts)):
        st = unit.steady
        out_units[0, i, :len(UNIT_SERIES)] = (st.speed_rpm, st.head_m, st.flow_m3_s, st.torque_nm)
        controls = parts["control"].hooks.initial_controls or (st.stroke,)
        out_units[0, i, len(UNIT_SERIES):len(UNIT_SERIES) + len(controls)] = controls
    nodes = np.zeros(penstock.n_nodes)  # the head envelope of the plant's penstock (the common conduit)
    node_heads = penstock.functions["node_heads"]
    getattr(node_heads, "py_func", node_heads)(penstock.params, penstock.state, head0, steady.head_m, nodes)
    env_max, env_min = nodes.copy(), nodes.copy()
    diag = np.zeros(9)
    args = (upstream.params, upstream.state, tuple(unit_args), out_units, out_iter, out_signals, env_max, env_min,
            diag)
    if several:
        out_manifold = np.zeros((rows, len(MANIFOLD_SERIES) + 2 * n_units))
        out_manifold[0, :len(MANIFOLD_SERIES)] = (steady.head_m, steady.flow_m3_s, steady.flow_m3_s, steady.head_m)
        for i, st in enumerate(steady.units):
            out_manifold[0, len(MANIFOLD_SERIES) + 2 * i:len(MANIFOLD_SERIES) + 2 * i + 2] = (st.flow_m3_s,
                                                                                              steady.head_m)
        args += (penstock.params, penstock.state, manifold_state(n_units), out_manifold)

    compiled = bool(jit and units[0].compiled.jitted)
    loop = assemble(common, unit_parts, units[0].compiled, plant.solver.pressure_loop, compiled=compiled)
    status, k_done, wall = run_in_chunks(loop, args, n_steps, dt, n_sub, stride, progress)

    def signals_of(owner, n: int) -> dict:
        """The columns the common upstream part and unit ``owner`` recorded, by their component's names."""
        out = {}
        for j, (who, name) in enumerate(zip(owners, signal_names)):
            if who is None or who == owner:
                out[name if who is None or not several else name.split(".", 1)[1]] = out_signals[:n, j]
        return out

    message = "ok"
    all_time = np.arange(rows) * (dt * stride)
    if status == 0:  # a component may find the run invalid afterwards (e.g. a surge tank running dry)
        checks = [(None, part) for part in common.values()]
        checks += [(i, parts[kind]) for i, parts in enumerate(unit_parts)
                   for kind in ("conduit", "shaft", "downstream", "control")]
        for owner, part in checks:
            problem = part.hooks.error_for(all_time, signals_of(owner, rows))
            if problem:
                problem = problem if owner is None else units[owner].prefix() + problem
                if raise_on_failure:
                    raise NumericalError(problem)
                message, status = problem, -1
                break
    if status > 0:
        failed_step = int(k_done)
        n_rows = failed_step // stride + 1
        unit = units[int(diag[8])]
        what, details = _step_failure(unit.parts["turbine"], int(status), diag, "branch" if several else "penstock")
        message = f"{unit.prefix()}{what} at t = {diag[0]:.6g} s (step {failed_step + 1}): {details}"
        parts = [(None, p) for p in common.values()] + [(None, p) for p in unit.parts.values()]
        for _, part in parts:  # a component that failed first (e.g. the generator's network) says why
            why = part.hooks.failure_reason()
            if why:
                message = f"{unit.prefix()}{why} (then the turbine boundary stopped: {what})"
                break
        if raise_on_failure:
            raise NumericalError(message)
    else:
        n_rows = rows
    time_s = all_time[:n_rows]
    return _result(plant, units, steady, common, penstock, time_s, n_rows, out_units, out_iter, out_signals,
                   signal_names, signals_of, out_manifold if several else None, env_max, env_min, diag, n_steps,
                   dt, n_sub, stride, compiled, status, message, wall, warnings)


def _result(plant, units, steady, common, penstock, time_s, n_rows, out_units, out_iter, out_signals, signal_names,
            signals_of, out_manifold, env_max, env_min, diag, n_steps, dt, n_sub, stride, compiled, status, message,
            wall, warnings) -> SimulationResult:
    """The record of the run: every unit's series, extrapolation record and component figures, the meta and the
    warnings (the plant-level series are the first event unit's with several units)."""
    from simulate.components.turbine.step_up import step_up_of
    from simulate.loop.domain import extrapolation_record, extrapolation_warnings, units_record
    from simulate.results.reversal import reversal_figures

    several = out_manifold is not None
    pen = plant.penstock
    series, component_figures = {}, {}
    meta = {"scenario": plant.scenario.kind, "penstock_model": pen.model,
            "pressure_loop": plant.solver.pressure_loop, "dt_s": dt, "substeps": n_sub,
            "pressure_loop_fallback_steps": int(diag[7]), "travel_time_s": pen.travel_time_s, "compiled": compiled}
    if several:
        meta.update({"dt_chosen": False,
                     "dt_limited_by": "the MOC grid ((shortest travel time of the conduit and the branches) / "
                                      "penstock.reaches)",
                     "unit_names": [u.name for u in units], "event_units": list(plant.event_units),
                     "initial_manifold_head_m": steady.head_m,
                     "steady_state_max_residual": max(abs(v) for u in units for v in u.steady.residuals.values())})
    else:
        plan, turbine = units[0].plan, plant.turbine
        meta.update({"dt_chosen": plan.chosen, "dt_limited_by": plan.limited_by,
                     "aligned_event_times_s": list(plan.aligned_events_s),
                     "moved_event_times_s": [{"requested_s": t, "acts_from_s": a} for t, a in plan.moved_events_s],
                     "water_time_s": pen.water_time_s(turbine.rated_flow_m3_s, turbine.rated_head_m),
                     "steady_state_max_residual": max(abs(v) for v in steady.residuals.values())})
        step_up = step_up_of(units[0].chars)
        if step_up is not None:  # the model chart converted to the prototype: what was assumed goes with the figures
            meta["step_up"] = step_up
    if stride != 1:
        meta["output_dt_s"] = dt * stride

    signals = {name: out_signals[:n_rows, j].copy() for j, name in enumerate(signal_names)}
    if several:
        signals["manifold_head_m"] = out_manifold[:n_rows, 0].copy()
        signals["manifold_flow_m3_s"] = out_manifold[:n_rows, 1].copy()
    for i, unit in enumerate(units):
        speed, head, flow, torque = (out_units[:n_rows, i, j].copy() for j in range(len(UNIT_SERIES)))
        stroke = out_units[:n_rows, i, len(UNIT_SERIES)].copy()
        sched, t = unit.schedules, unit.view.turbine
        ref_end = 0.0
        if sched.mode == GOVERNOR:
            from simulate.components.schedules import piecewise_constant

            # py_func: a one-off call from Python need not load the compiled version from the disk cache
            ref_end = float(getattr(piecewise_constant, "py_func", piecewise_constant)(
                sched.ref_times_s, sched.ref_values, time_s[-1] + 1e-9 * dt, 0.0))
        n11 = speed * t.runner_diameter_m / np.sqrt(np.maximum(head, HEAD_FLOOR_FRACTION * t.rated_head_m))
        figure_times = {"max_speed_rise": float(time_s[largest_speed_index(speed)]),
                        "max_head_rise": float(time_s[int(np.argmax(head))])}
        if not several:  # the plant-level record of several units covers the figures worst over the units
            figure_times["min_head_drop"] = float(time_s[int(np.argmin(head))])
        record = extrapolation_record(unit.domain, time_s, n11, stroke * t.opening_max, stroke,
                                      figure_times=figure_times)
        series[unit.name] = {"speed_rpm": speed, "head_m": head, "flow_m3_s": flow, "opening": stroke,
                             "opening_chart": stroke * t.opening_max, "torque_nm": torque,
                             "power_mw": torque * speed * (2.0 * math.pi / 60.0) * 1e-6,
                             "iterations": out_iter[:n_rows, i].copy(),
                             "speed_reference_rpm": t.rated_speed_rpm * (1.0 + ref_end), "extrapolation": record}

    # the components' figures and warnings: the common parts on the plant's signals, each unit's on its own
    plant_signals = signals if several else {n: out_signals[:n_rows, j] for j, n in enumerate(signal_names)}
    upstream = common["upstream"]
    meta.update(upstream.hooks.summary)
    figures = upstream.hooks.figures_after(time_s, plant_signals)
    meta.update(figures)
    component_figures.update(figures)
    if several:
        meta.update({f"conduit_{k}": v for k, v in common["penstock"].hooks.summary.items()})
    for i, unit in enumerate(units):
        own = signals_of(i, n_rows)
        # the turbine's summary last: a boundary that solves its own equation says so over solver.pressure_loop
        kinds = (("shaft", "downstream", "control") if several else ("conduit", "shaft", "downstream", "control")) \
            + ("turbine",)
        for kind in kinds:
            part = unit.parts[kind]
            meta.update(part.hooks.summary)
            figures = {(k if not several else f"{unit.name}.{k}"): v
                       for k, v in part.hooks.figures_after(time_s, own).items()}
            meta.update(figures)
            component_figures.update(figures)
    for unit in units:  # the figures of a unit that can reverse: declared by its characteristics' kind
        if unit.kind is not None and kind_of(unit.kind).four_quadrant:
            own = series[unit.name]
            figures = reversal_figures(time_s, own["speed_rpm"], own["flow_m3_s"], own["opening"],
                                       unit.view.turbine.rated_speed_rpm)
            figures = {(k if not several else f"{unit.name}.{k}"): v for k, v in figures.items()}
            meta.update(figures)
            component_figures.update(figures)
    for unit in units:
        warnings += [unit.note(w) for w in extrapolation_warnings(series[unit.name]["extrapolation"])]
    warnings += upstream.hooks.warnings_for(plant_signals)
    for i, unit in enumerate(units):
        own = signals_of(i, n_rows)
        for kind in ("conduit", "shaft", "downstream", "control"):
            warnings += [unit.note(w) for w in unit.parts[kind].hooks.warnings_for(own)]
    fallback_steps = int(diag[7])
    if fallback_steps > 0 and several:
        warnings.append(f"the pressure loop '{plant.solver.pressure_loop}' did not converge at {fallback_steps} unit "
                        f"steps of {n_steps} steps and its fallback solved them: set solver.pressure_loop = "
                        f"\"newton\" or a smaller solver.relaxation for a faster run")
    elif fallback_steps > 0:
        warnings.append(f"the pressure loop '{plant.solver.pressure_loop}' did not converge at {fallback_steps} of "
                        f"{n_steps} steps and its fallback (relaxation "
                        f"{FALLBACK_DAMPING * plant.solver.relaxation:g}, then Newton) solved them: set "
                        f"solver.pressure_loop = \"newton\" or a smaller solver.relaxation for a faster run")

    envelope = {"envelope_x_m": np.asarray(penstock.node_x_m, float), "envelope_max_m": env_max,
                "envelope_min_m": env_min}
    if not several:
        unit = units[0]
        meta["extrapolation"] = series[None]["extrapolation"]
        meta["warnings"] = warnings
        lead = dict(series[None])
        lead.pop("extrapolation")
        return SimulationResult(time_s=time_s, **lead, rated_speed_rpm=plant.turbine.rated_speed_rpm,
                                success=status == 0, message=message, meta=meta, wall_time_s=wall, signals=signals,
                                **envelope, steady=steady, plant=plant, characteristics=unit.chars,
                                component_figures=component_figures)
    event_units = plant.event_units
    lead = event_units[0] if event_units else units[0].name
    lead_index = [u.name for u in units].index(lead)
    meta["series_unit"] = lead
    junction = {name: out_manifold[:n_rows, j].copy() for j, name in enumerate(MANIFOLD_SERIES)}
    for i, unit in enumerate(units):
        junction[f"{unit.name}.branch_inlet_flow_m3_s"] = out_manifold[:n_rows, len(MANIFOLD_SERIES) + 2 * i].copy()
        junction[f"{unit.name}.branch_inlet_head_m"] = out_manifold[:n_rows, len(MANIFOLD_SERIES) + 2 * i + 1].copy()
    # the plant-level figures are the worst over the units (SimulationResult.summary): so is their record
    worst = worst_over_units({u.name: unit_figures(time_s, series[u.name], u.view.turbine.rated_speed_rpm)
                              for u in units})
    meta["extrapolation"] = units_record({name: s["extrapolation"] for name, s in series.items()},
                                         {figure: worst[f"{figure}_unit"] for figure in ("max_speed_rise",
                                                                                         "max_head_rise")
                                          if f"{figure}_unit" in worst}, lead)
    meta["warnings"] = warnings
    lead_series = {k: v for k, v in series[lead].items() if k != "extrapolation"}
    return SimulationResult(
        time_s=time_s, **lead_series, rated_speed_rpm=units[lead_index].view.turbine.rated_speed_rpm,
        success=status == 0, message=message, meta=meta, wall_time_s=wall, signals=signals, **envelope,
        steady=steady, plant=plant, characteristics=units[lead_index].chars, units=series, junction=junction,
        component_figures=component_figures)
