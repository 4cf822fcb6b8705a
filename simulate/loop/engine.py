"""The time loop, assembled from compiled components (see :mod:`simulate.components.registry`,
:mod:`simulate.loop.assembly`).

Per step k -> k+1 (t = k dt):

1. control: the control vector at t_{k+1} from the named signals at t_k (:mod:`simulate.components.signals`: the
   governor's law + servo, or a prescribed law);
2. shaft: the speed at t_{k+1} from the turbine torque and the load at t_k (explicit Euler);
3. penstock: the linear relation H = C_L + k Q at the turbine, with the upstream head of this step;
4. turbine boundary: (H, Q) at n_{k+1} and the controls by the chosen pressure loop; turbine torque M11 D1^3 H;
5. penstock and upstream (reservoir or surge tank) updates; the head envelope at every computing node.

The loop runs in chunks of about :data:`CHUNK_WALL_S` of work, so Ctrl-C is honoured between chunks (the compiled
code cannot be interrupted). With characteristics that offer no numba kernel, or ``jit=False``, the same generated
source runs as plain Python.
"""

from __future__ import annotations

import math
import threading
import weakref

import numpy as np

from hillchart.errors import NumericalError
from simulate.components.turbine.boundary import FALLBACK_DAMPING, STATUS_TEXT, turbine_parameters, turbine_state
from simulate.components.turbine.component import characteristics_of
from simulate.config import PlantConfig
from simulate.results.result import SimulationResult
from simulate.scenarios import GOVERNOR, build_schedules, initial_target
from simulate.loop.steady import SteadyState, steady_state

from simulate.loop.common import (  # noqa: F401  (the loop's shared settings, re-exported here)
    CHUNK_WALL_S, CLOSED_STROKE, FAILURE_ADVICE, HEAD_FLOOR_FRACTION, SEPARATION_ADVICE, SEPARATION_FRACTION,
    _failure_advice, run_in_chunks, step_count, upstream_friction_s2_m5)


def downstream_friction_s2_m5(plant: PlantConfig) -> float:
    """Steady head loss coefficient K Q|Q| below the runner (a ``[draft_tube]``), s^2/m^5."""
    config = getattr(plant, "draft_tube", None)
    return 0.0 if config is None else config.friction_coefficient_s2_m5


def plant_characteristics(plant: PlantConfig, characteristics):
    """The characteristics as the plant uses them (three-input ones seen through the combinator, see
    :mod:`simulate.components.turbine.double_regulated`); two-input ones unchanged."""
    def count_inputs():
        import inspect

        q11 = getattr(characteristics, "q11", None)
        try:
            return len(inspect.signature(q11).parameters) if q11 is not None else 2
        except (TypeError, ValueError):
            return 2

    inputs = _memo(characteristics, ("inputs",), count_inputs)  # inspect.signature: 0.1 ms a run
    if inputs != 3 and getattr(plant, "combinator", None) is None and getattr(plant, "blade_servo", None) is None:
        return characteristics  # a single-regulated unit: nothing to import
    from simulate.components.turbine.double_regulated import plant_characteristics as view

    return view(plant, characteristics)


#: Per characteristics object (weakly held): the steady states and trusted domains already computed, by their
#: inputs. A batch of cases that share a load case (a sweep of closing times, an optimizer's generations) finds its
#: steady state once; a hit returns the very object a fresh computation would equal bit for bit (the same inputs
#: through the same code).
_MEMO: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
#: Entries kept per characteristics object before the memo of that object starts again.
MEMO_ENTRIES = 4096
_MEMO_LOCK = threading.Lock()


def _memo(characteristics, key: tuple, compute):
    """``compute()``, remembered per ``characteristics`` (when it can be weakly referenced) by ``key``."""
    try:
        hash(key)
        with _MEMO_LOCK:  # runs on several threads (simulate.loop.parallel)
            table = _MEMO.setdefault(characteristics, {})
    except TypeError:  # not weakly referenceable, or a key that cannot be hashed: nothing remembered
        return compute()
    found = table.get(key)
    if found is None:
        found = compute()
        with _MEMO_LOCK:
            if len(table) >= MEMO_ENTRIES:
                table.clear()
            found = table.setdefault(key, found)
    return found


def initial_state(plant: PlantConfig, characteristics=None) -> SteadyState:
    """The verified steady state a run of ``plant`` starts from (see :mod:`simulate.loop.steady`).

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml", {"turbine.characteristics": "ideal"})
    >>> s = initial_state(plant)
    >>> round(s.power_mw, 9), s.speed_rpm, max(abs(v) for v in s.residuals.values()) < 1e-9
    (225.0, 200.0, True)
    """
    from hillchart.characteristics import scalar_kernel

    view = plant_characteristics(plant, characteristics_of(plant, characteristics))
    friction = plant.penstock.friction_coefficient_s2_m5
    extra = upstream_friction_s2_m5(plant)
    if extra:
        friction = friction + extra
    below = downstream_friction_s2_m5(plant)
    if below:
        friction = friction + below
    target = initial_target(plant.scenario)
    inputs = ("steady", plant.turbine, plant.penstock.static_head_m, friction, plant.governor.stroke_min,
              plant.governor.stroke_max, tuple(sorted(target.items())))

    def compute():
        # a double-regulated unit: values at the cam through the compiled kernel (the steady state reads no
        # derivative)
        kernel, params = view.steady_kernel() if hasattr(view, "steady_kernel") else scalar_kernel(view)[:2]
        return steady_state(kernel, params, turbine=plant.turbine, static_head_m=plant.penstock.static_head_m,
                            friction_s2_m5=friction, stroke_min=plant.governor.stroke_min,
                            stroke_max=plant.governor.stroke_max, **target)

    return _memo(view, inputs, compute)


def plant_schedules(plant: PlantConfig, steady: SteadyState):
    """The scenario's schedules from the steady state ``steady``."""
    return build_schedules(plant, steady.stroke, steady.torque_nm / plant.turbine.rated_torque_nm)


def build_parts(plant: PlantConfig, steady: SteadyState, dt_s: float, substeps: int = 1,
                characteristics=None, schedules=None) -> dict:
    """The compiled components of ``plant`` by kind (penstock, upstream, control, shaft, downstream), from the
    registries, and the scenario's schedules (``schedules``: those of :func:`plant_schedules`, when the caller has
    them). Control and shaft are built for the sub-step ``dt_s / substeps`` (see :mod:`simulate.loop.timestep`).
    ``characteristics``: those the run uses (default the plant's own, :func:`simulate.components.turbine.component.
    characteristics_of`); a double-regulated unit's blade control reads their plant view's cam."""
    from simulate.components.registry import (CONTROLS, DOWNSTREAM, PENSTOCKS, SHAFTS, UPSTREAM, control_name,
                                              downstream_section, shaft_section, upstream_section)

    schedules = plant_schedules(plant, steady) if schedules is None else schedules
    sub_dt = dt_s / substeps
    upstream = UPSTREAM.builder(upstream_section(plant)[0])(plant, steady, dt_s)
    head0 = upstream.hooks.initial_head_m
    head0 = plant.penstock.static_head_m if head0 is None else head0
    parts = {
        "upstream": upstream,
        "penstock": PENSTOCKS.builder(plant.penstock.model)(plant, steady, dt_s, head0),
        "shaft": SHAFTS.builder(shaft_section(plant)[0])(plant, steady, sub_dt, schedules),
        "downstream": DOWNSTREAM.builder(downstream_section(plant)[0])(plant, steady, dt_s),
    }
    control = control_name(plant, schedules)
    extra = {"characteristics": plant_characteristics(plant, characteristics_of(plant, characteristics))} \
        if control.endswith("_blades") else {}
    parts["control"] = CONTROLS.builder(control)(plant, steady, sub_dt, schedules, **extra)
    return parts, schedules


def run_simulation(plant: PlantConfig, characteristics=None, *, jit: bool = True,
                   raise_on_failure: bool = True, progress=None) -> SimulationResult:
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
    progress : callable, optional
        Called as ``progress(step, n_steps)`` between chunks of the loop.

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
    if plant.units:  # several units on a conduit that branches at a manifold
        from simulate.loop.multi_unit import run_units

        return run_units(plant, characteristics, jit=jit, raise_on_failure=raise_on_failure, progress=progress)
    from simulate.loop import guards
    from simulate.loop.assembly import RECORDING_KINDS, assemble
    from simulate.components.signals import check_provided, initial_signals
    from simulate.components.turbine.evaluation import compile_characteristics
    from simulate.components.turbine.step_up import step_up_of
    from simulate.loop.timestep import plan_step

    plant.time_step_s  # noqa: B018  (the Courant check of the grid before anything heavier)
    chars = plant_characteristics(plant, characteristics_of(plant, characteristics))
    compiled_chars = _memo(chars, ("compiled",), lambda: compile_characteristics(chars))
    turbine, pen = plant.turbine, plant.penstock
    from simulate.loop.domain import extrapolation_record, extrapolation_warnings, plant_domain

    domain_key = ("domain", plant.turbine.characteristics, str(plant.base_dir))
    domain = _memo(chars, domain_key, lambda: plant_domain(plant, chars))
    steady = initial_state(plant, chars)
    schedules = plant_schedules(plant, steady)
    plan = plan_step(plant, schedules)  # the step from the components' time scales
    dt, n_sub = plan.dt_s, plan.substeps
    n_steps = step_count(plant.scenario.t_end_s, dt)
    stride = guards.output_stride(plant, dt)
    guards.check_run_size(plant, dt, n_steps, stride, n_sub)
    guards.check_initial_state(plant, steady, domain, remember=lambda key, compute: _memo(chars, key + domain_key,
                                                                                          compute))
    warnings = guards.plausibility_warnings(plant) + list(plan.warnings)
    training = getattr(chars, "training", None)
    if isinstance(training, dict) and training.get("kind") == "on-cam":  # nets of a chart without vane angles
        from hillchart.fccm.on_cam import ON_CAM_WARNING

        warnings.append(ON_CAM_WARNING)
    if getattr(chars, "cam_warning", None):  # the nets' cam and their fitted model's disagree
        warnings.append(chars.cam_warning)
    parts, schedules = build_parts(plant, steady, dt, n_sub, chars, schedules)

    tp = turbine_parameters(turbine, plant.solver, head_floor_m=HEAD_FLOOR_FRACTION * turbine.rated_head_m,
                            closed_stroke=CLOSED_STROKE, control_scales=[turbine.opening_max] + [1.0] * (
                                parts["control"].hooks.n_controls - 1))
    n_controls = parts["control"].hooks.n_controls
    ts = turbine_state(steady.head_m, steady.flow_m3_s, steady.torque_nm, n_controls)
    rows = n_steps // stride + 1
    out = {name: np.zeros(rows) for name in ("speed", "head", "flow", "torque")}
    out_iter = np.zeros(rows, dtype=np.int64)
    out_controls = np.zeros((rows, n_controls))
    signal_names = [name for kind in RECORDING_KINDS for name in parts[kind].signals]
    out_signals = np.zeros((rows, len(signal_names)))
    out["speed"][0], out["head"][0], out["flow"][0] = steady.speed_rpm, steady.head_m, steady.flow_m3_s
    out["torque"][0] = steady.torque_nm
    out_controls[0, :] = parts["control"].hooks.initial_controls or [steady.stroke]
    pen_part, up_part = parts["penstock"], parts["upstream"]
    column = 0
    for kind in RECORDING_KINDS:  # row 0: each recording component's initial signals
        if parts[kind].signals:
            out_signals[0, column:column + len(parts[kind].signals)] = parts[kind].hooks.initial_signals
            column += len(parts[kind].signals)
    nodes = np.zeros(pen_part.n_nodes)
    node_heads = pen_part.functions["node_heads"]
    head0 = up_part.hooks.initial_head_m
    getattr(node_heads, "py_func", node_heads)(pen_part.params, pen_part.state,
                                               pen.static_head_m if head0 is None else head0, steady.head_m, nodes)
    env_max, env_min = nodes.copy(), nodes.copy()
    diag = np.zeros(8)

    check_provided(parts["control"], parts["shaft"])
    sig = initial_signals(parts["control"], parts["shaft"], steady.head_m, steady.torque_nm)

    compiled = bool(jit and compiled_chars.jitted)
    loop = assemble(parts, compiled_chars, plant.solver.pressure_loop, compiled=compiled)
    args = (compiled_chars.params, tp, ts, pen_part.params, pen_part.state, up_part.params, up_part.state,
            parts["control"].params, parts["control"].state, parts["shaft"].params, parts["shaft"].state,
            parts["downstream"].params, parts["downstream"].state,
            out["speed"], out["head"], out["flow"], out["torque"], out_iter, out_controls, out_signals,
            env_max, env_min, diag, sig)
    status, k_done, wall = run_in_chunks(loop, args, n_steps, dt, n_sub, stride, progress)

    message = "ok"
    if status == 0:  # a component may find the run invalid afterwards (e.g. a surge tank running dry)
        all_signals = {name: out_signals[:, j] for j, name in enumerate(signal_names)}
        all_time = np.arange(rows) * (dt * stride)
        for part in parts.values():
            problem = part.hooks.error_for(all_time, all_signals)
            if problem:
                if raise_on_failure:
                    raise NumericalError(problem)
                message, status = problem, -1
                break
    if status > 0:
        failed_step = int(k_done)
        n_rows = failed_step // stride + 1
        message = (f"pressure loop '{plant.solver.pressure_loop}' failed ({STATUS_TEXT[int(status)]}) at t = "
                   f"{diag[0]:.6g} s (step {failed_step + 1}): speed {diag[1]:.6g} r/min, opening {diag[2]:.6g} "
                   f"(chart units), head guess {diag[3]:.6g} m, penstock relation H = {diag[4]:.6g} + "
                   f"({diag[5]:.6g}) Q, last head residual {diag[6]:.3g} m (tolerance {tp[0][2]:.3g} m, "
                   f"{plant.solver.max_iterations} iterations, relaxation {plant.solver.relaxation}"
                   + _failure_advice(int(status), plant.solver, diag[4], turbine.rated_head_m))
        for part in parts.values():  # a component that failed first (e.g. the generator's network) says why
            why = part.hooks.failure_reason()
            if why:
                message = f"{why} (the pressure loop then stopped: {STATUS_TEXT[int(status)]})"
                break
        if raise_on_failure:
            raise NumericalError(message)
    else:
        n_rows = rows
    time_s = np.arange(n_rows) * (dt * stride)
    speed = out["speed"][:n_rows]
    torque = out["torque"][:n_rows]
    stroke = out_controls[:n_rows, 0]
    ref_end = 0.0
    if schedules.mode == GOVERNOR:
        from simulate.components.schedules import piecewise_constant

        # py_func: a one-off call from Python need not load the compiled version from the disk cache
        ref_end = float(getattr(piecewise_constant, "py_func", piecewise_constant)(
            schedules.ref_times_s, schedules.ref_values, time_s[-1] + 1e-9 * dt, 0.0))
    tw = pen.water_time_s(turbine.rated_flow_m3_s, turbine.rated_head_m)
    meta = {"scenario": plant.scenario.kind, "penstock_model": pen.model,
            "pressure_loop": plant.solver.pressure_loop, "dt_s": dt, "substeps": n_sub,
            "dt_chosen": plan.chosen, "dt_limited_by": plan.limited_by,
            "aligned_event_times_s": list(plan.aligned_events_s),
            "moved_event_times_s": [{"requested_s": t, "acts_from_s": a} for t, a in plan.moved_events_s],
            "pressure_loop_fallback_steps": int(diag[7]), "water_time_s": tw,
            "travel_time_s": pen.travel_time_s, "compiled": compiled,
            "steady_state_max_residual": max(abs(v) for v in steady.residuals.values())}
    step_up = step_up_of(chars)
    if step_up is not None:  # the model chart converted to the prototype: what was assumed goes with the figures
        meta["step_up"] = step_up
    if stride != 1:
        meta["output_dt_s"] = dt * stride
    component_figures = {}
    for part in parts.values():
        meta.update(part.hooks.summary)
        figures = part.hooks.figures_after(time_s, {name: out_signals[:n_rows, j]
                                                    for j, name in enumerate(signal_names)})
        meta.update(figures)
        component_figures.update(figures)
    head = out["head"][:n_rows]
    n11 = speed * turbine.runner_diameter_m / np.sqrt(np.maximum(head, HEAD_FLOOR_FRACTION * turbine.rated_head_m))
    figure_times = {"max_speed_rise": float(time_s[int(np.argmax(speed))]),
                    "max_head_rise": float(time_s[int(np.argmax(head))]),
                    "min_head_drop": float(time_s[int(np.argmin(head))])}
    meta["extrapolation"] = extrapolation_record(domain, time_s, n11, stroke * turbine.opening_max, stroke,
                                                 figure_times=figure_times)
    warnings += extrapolation_warnings(meta["extrapolation"])
    for part in parts.values():
        warnings += part.hooks.warnings_for(
            {name: out_signals[:n_rows, j] for j, name in enumerate(signal_names)})
    if diag[7] > 0:
        warnings.append(f"the pressure loop '{plant.solver.pressure_loop}' did not converge at {int(diag[7])} of "
                        f"{n_steps} steps and its fallback (relaxation "
                        f"{FALLBACK_DAMPING * plant.solver.relaxation:g}, then Newton) solved them: set "
                        f"solver.pressure_loop = \"newton\" or a smaller solver.relaxation for a faster run")
    meta["warnings"] = warnings
    signals = {name: out_signals[:n_rows, j].copy() for j, name in enumerate(signal_names)}
    return SimulationResult(
        time_s=time_s, speed_rpm=speed, head_m=out["head"][:n_rows], flow_m3_s=out["flow"][:n_rows],
        opening=stroke, opening_chart=stroke * turbine.opening_max,
        torque_nm=torque, power_mw=torque * speed * (2.0 * math.pi / 60.0) * 1e-6, iterations=out_iter[:n_rows],
        speed_reference_rpm=turbine.rated_speed_rpm * (1.0 + ref_end), rated_speed_rpm=turbine.rated_speed_rpm,
        success=status == 0, message=message, meta=meta, wall_time_s=wall, signals=signals,
        envelope_x_m=np.asarray(pen_part.node_x_m, float), envelope_max_m=env_max, envelope_min_m=env_min,
        steady=steady, plant=plant, characteristics=chars, component_figures=component_figures)
