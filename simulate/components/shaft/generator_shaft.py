"""The sub-transient generator on the shaft: registry kind "shaft", name ``subtransient`` (``[generator] model =
"subtransient"``; see :mod:`simulate.components.registry`).

It joins the pieces of :mod:`simulate.components.electrical` (paper 001 eq. (10) and its grid),
:mod:`simulate.components.control.excitation` (eqs. (11)-(13)) and the swing equation of
:mod:`simulate.components.shaft.rotor` into one shaft component with the kind's fixed signature, so the assembled
time loop runs it without naming it. Per loop step k -> k+1 (the order of
:func:`simulate.components.electrical.standalone.simulate_unit`):

1. network solution at (state_k, x_k) with the inputs at t_k -> air-gap torque Te_k, terminal voltage V_k;
2. field voltage for [t_k, t_k+1): the excitation's PI on V_k, or held (``short-circuit``, ``field-step``: the
   steady field, plus ``field_step_pu`` from ``event_time_s``);
3. rotor: ``x_k+1 = rotor_step(x_k, m_t_k, Te_k * rated_mva / P_r, 0, Ta, dt)`` (the swing equation with the
   generator's air-gap torque as its load; the load's frequency dependence is in the grid), or x held at 0;
4. :func:`simulate.components.electrical.generator.generator_step` from t_k to t_k+1 at the NEW speed x_k+1
   (semi-implicit: the angle integrates x_k+1 - x_bus, see the README; x_bus the infinite bus's frequency
   deviation of the scenario ``grid-frequency-step``, 0 otherwise).

Steps 1-2 of step k+1 are done at the end of step k (same order, shifted), so the record of row k+1 shows the
network at t_k+1 and the field voltage applied from t_k+1 on, the convention of the standalone drivers.

The scenario's schedules become the network's inputs: the breaker is closed while the scenario's load is positive
(a load rejection opens it; the no-load kinds run at open circuit), the island load is the schedule's load divided
by the initial load, and the electrical events (terminal fault, held speed and field, field step) and the infinite
bus's frequency steps come from :class:`simulate.scenarios.Schedules`. An event inside a step (a load change, the
fault, the field step, a bus frequency step) splits the generator's step at its time.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from simulate.components.contract import ENTRIES, StateArray
from simulate.components.control.excitation import EXC_STATE, excitation_step
from simulate.components.electrical.generator import (
    GEN_OUTPUTS,
    GEN_STATE,
    O_ID,
    O_IQ,
    O_PE,
    O_TE,
    O_VT,
    P_TORQUE_RATIO,
    S_ED_ST,
    S_EQ_ST,
    S_EQ_T,
    STATUS_TEXT,
    generator_step,
    network_solution,
)
from simulate.components.electrical.standalone import RUN_COLUMNS
from simulate.components.schedules import piecewise_constant
from simulate.components.shaft.rotor import SPEED, rotor_step
from simulate.components.shaft.rotor import linear_counterpart  # noqa: F401  (the swing equation's, the island's e_g)
from simulate.components.signals import RPM_NM_TO_MW

#: The extra timeseries columns (the standalone drivers' :data:`simulate.components.electrical.standalone.RUN_COLUMNS`
#: without time).
SIGNALS = tuple(c for c in RUN_COLUMNS if c != "time_s")

#: Layout of the scalar parameter vector.
SHAFT_SCALARS = ("rated_speed_rpm", "rated_torque_nm", "inertia_time_s", "time_eps_s", "initial_load_pu",
                 "speed_held", "fault_time_s", "field_held", "field_step_time_s", "field_step_pu",
                 "steady_field_pu", "rated_frequency_hz", "infinite_bus")
(C_NR, C_MR, C_TA, C_EPS, C_LOAD0, C_SPEED_HELD, C_FAULT_T, C_FIELD_HELD, C_FIELD_T, C_FIELD_STEP, C_FIELD0,
 C_FN, C_BUS) = range(len(SHAFT_SCALARS))
#: Layout of the small state vector ``misc``: field voltage held over the coming step, failure status, its time, the
#: infinite bus's per-unit frequency deviation x_bus at the present time.
M_FIELD, M_STATUS, M_TIME, M_XBUS = 0, 1, 2, 3
#: The layout of the scratch array of :func:`simulate.components.electrical.generator.generator_step`: the outputs,
#: the four Runge-Kutta stages and a temporary state.
WORK = (tuple(f"output_{name}" for name in GEN_OUTPUTS)
        + tuple(f"k{i}_{name}" for i in range(1, 5) for name in GEN_STATE) + tuple(f"tmp_{name}" for name in GEN_STATE))
#: Its state: the speed, the machine's and the excitation's states, the network's outputs, the scratch array, misc.
STATES = (SPEED,
          StateArray("generator", "pu; pu; pu; rad", "the machine's fluxes and rotor angle (eq. (10))", ENTRIES,
                     entries=GEN_STATE),
          StateArray("excitation", "pu; pu", "the excitation's filtered error and integral", ENTRIES,
                     entries=EXC_STATE),
          StateArray("outputs", "pu", "the network's solution of the last step", ENTRIES, entries=GEN_OUTPUTS),
          StateArray("work", "pu", "scratch of the Runge-Kutta step (no allocation in the loop)", ENTRIES,
                     entries=WORK),
          StateArray("misc", "pu; 1; s; pu", "the field voltage held over the step, the failure status, its time, "
                     "the infinite bus's frequency deviation", ENTRIES,
                     entries=("field_voltage_pu", "status", "failure_time_s", "bus_speed_deviation")))


@numba.njit(cache=True)
def _inputs(scal, load_times, load_values, t_s):
    """(breaker, island load scale, fault) at ``t_s`` from the scenario's schedules."""
    eps = scal[C_EPS]
    load = piecewise_constant(load_times, load_values, t_s + eps, scal[C_LOAD0])
    breaker = 1.0 if load > 0.0 else 0.0
    scale = load / scal[C_LOAD0] if scal[C_LOAD0] > 0.0 else 0.0
    fault = 1.0 if t_s >= scal[C_FAULT_T] - eps else 0.0
    return breaker, scale, fault


@numba.njit(cache=True)
def _bus_deviation(scal, bus_times, bus_values, t_s):
    """The infinite bus's per-unit frequency deviation x_bus from ``t_s`` on (0 before the first step)."""
    return piecewise_constant(bus_times, bus_values, t_s + scal[C_EPS], 0.0)


@numba.njit(cache=True)
def _event_within(scal, load_times, bus_times, t_s, dt_s):
    """The first electrical event (load change, fault, field step, bus frequency step) strictly inside
    (t_s, t_s + dt_s), or t_s + dt_s when there is none."""
    eps = scal[C_EPS]
    first = t_s + dt_s
    for t_e in (scal[C_FAULT_T], scal[C_FIELD_T]):
        if t_s + eps < t_e < first - eps:
            first = t_e
    for t_e in load_times:
        if t_s + eps < t_e < first - eps:
            first = t_e
    for t_e in bus_times:
        if t_s + eps < t_e < first - eps:
            first = t_e
    return first


@numba.njit(cache=True)
def _network_and_field(scal, gp, ep, load_times, load_values, gs, es, out, misc, x, t_s, dt_s):
    """Steps 1-2 at ``t_s``: the network outputs into ``out`` and the field voltage for [t_s, t_s + dt) into
    ``misc``. Returns the status."""
    breaker, scale, fault = _inputs(scal, load_times, load_values, t_s)
    status = network_solution(gp, gs, x, breaker, scale, fault, out)
    if status != 0:
        return status
    if scal[C_FIELD_HELD] > 0.5:
        misc[M_FIELD] = scal[C_FIELD0] + (scal[C_FIELD_STEP] if t_s >= scal[C_FIELD_T] - scal[C_EPS] else 0.0)
    else:
        misc[M_FIELD] = excitation_step(ep, es, out[O_VT], dt_s)  # eqs. (11)-(13)
    return 0


@numba.njit(cache=True)
def subtransient_speed(p, s):
    return s[0][0]


@numba.njit(cache=True)
def subtransient_electrical_power(p, s, t_s):
    """The electrical power at the terminals, MW, of the network solution at the present state: machine-base per
    unit x rated MVA (= x torque ratio x P_r, P_r = m_r n_r on the turbine's base)."""
    scal, gp = p[0], p[1]
    out = s[3]
    return out[O_PE] * gp[P_TORQUE_RATIO] * scal[C_MR] * scal[C_NR] * RPM_NM_TO_MW


@numba.njit(cache=True)
def subtransient_grid_frequency(p, s):
    """The grid's frequency, Hz: the island's is the unit's, f_n n / n_r; the infinite bus's f_n (1 + x_bus)."""
    scal = p[0]
    if scal[C_BUS] > 0.5:
        return scal[C_FN] * (1.0 + s[5][M_XBUS])
    return scal[C_FN] * s[0][0] / scal[C_NR]


@numba.njit(cache=True)
def subtransient_shaft_step(p, s, turbine_torque_nm, t_s, dt_s):
    """Steps 3-4 of step k, then 1-2 of step k+1 (module docstring). A failure of the network or of the generator
    step stores its status and time and returns NaN (the run then stops; the engine reports the status)."""
    scal, gp, ep, load_times, load_values, bus_times, bus_values = p
    speed, gs, es, out, work, misc = s
    if misc[M_STATUS] != 0.0:
        return math.nan
    n_r = scal[C_NR]
    x = speed[0] / n_r - 1.0
    if scal[C_SPEED_HELD] > 0.5:
        x_next = x
    else:
        # the swing equation; its load is the air-gap torque on the turbine torque base
        x_next = rotor_step(x, turbine_torque_nm / scal[C_MR], out[O_TE] * gp[P_TORQUE_RATIO], 0.0, scal[C_TA], dt_s)
    breaker, scale, fault = _inputs(scal, load_times, load_values, t_s)
    x_bus = _bus_deviation(scal, bus_times, bus_values, t_s)
    t_event = _event_within(scal, load_times, bus_times, t_s, dt_s)
    if t_event < t_s + dt_s:  # an event inside the step: the fluxes meet it at its time (the step is split)
        status = generator_step(gp, gs, x_next, misc[M_FIELD], breaker, scale, fault, t_event - t_s, work, x_bus)
        if status == 0:
            breaker, scale, fault = _inputs(scal, load_times, load_values, t_event)
            x_bus = _bus_deviation(scal, bus_times, bus_values, t_event)
            field = misc[M_FIELD]
            if scal[C_FIELD_HELD] > 0.5 and t_event >= scal[C_FIELD_T] - scal[C_EPS]:
                field = scal[C_FIELD0] + scal[C_FIELD_STEP]
            status = generator_step(gp, gs, x_next, field, breaker, scale, fault, t_s + dt_s - t_event, work, x_bus)
    else:
        status = generator_step(gp, gs, x_next, misc[M_FIELD], breaker, scale, fault, dt_s, work, x_bus)  # eq. (10)
    misc[M_XBUS] = _bus_deviation(scal, bus_times, bus_values, t_s + dt_s)
    if status == 0:
        status = _network_and_field(scal, gp, ep, load_times, load_values, gs, es, out, misc, x_next, t_s + dt_s,
                                    dt_s)
    if status != 0:
        misc[M_STATUS] = status
        misc[M_TIME] = t_s + dt_s
        return math.nan
    speed[0] = n_r * (1.0 + x_next)
    return speed[0]


@numba.njit(cache=True)
def subtransient_record(p, s, row):
    """The columns :data:`SIGNALS` of the present state into ``row``."""
    scal = p[0]
    speed, gs, out, misc = s[0], s[1], s[3], s[5]
    row[0] = out[O_VT]
    row[1] = out[O_ID]
    row[2] = out[O_IQ]
    row[3] = misc[M_FIELD]
    row[4] = out[O_PE]
    row[5] = gs[S_EQ_T]
    row[6] = gs[S_EQ_ST]
    row[7] = gs[S_ED_ST]
    row[8] = scal[C_FN] * speed[0] / scal[C_NR]


def build_subtransient(plant, steady, dt_s: float, schedules):
    """The shaft of ``[generator] model = "subtransient"``, ``[excitation]``, ``[grid]`` at the turbine's steady
    state (:func:`simulate.components.electrical.generator.compile_electrical`: the generator takes the scenario's
    initial load, the terminal voltage is the excitation's set point; residuals checked < 1e-9)."""
    from hillchart.errors import InputError
    from simulate.components.electrical.generator import compile_electrical
    from simulate.components.electrical.standalone import frequency_recovery_time
    from simulate.components.registry import CompiledPart, PartHooks

    t = plant.turbine
    electrical = plant.electrical
    load0 = float(schedules.initial_load)
    arrays = compile_electrical(electrical, turbine_power_mw=max(load0, 0.0) * t.rated_power_mw,
                                turbine_rated_power_mw=t.rated_power_mw, breaker_closed=load0 > 0.0)
    grid = electrical.grid
    warnings = electromechanical_step_check(plant, arrays, dt_s, schedules) + rating_check(plant, schedules)
    scal = np.array([t.rated_speed_rpm, t.rated_torque_nm, plant.generator.inertia_time_s, 1e-9 * dt_s, load0,
                     1.0 if schedules.speed_held else 0.0, schedules.fault_time_s,
                     1.0 if schedules.field_held else 0.0, schedules.field_step_time_s, schedules.field_step_pu,
                     arrays.field_voltage_pu, grid.frequency_hz, 1.0 if grid.kind == "infinite-bus" else 0.0])
    params = (scal, arrays.generator_params, arrays.excitation_params, schedules.load_times_s,
              schedules.load_values, schedules.bus_frequency_times_s, schedules.bus_frequency_values)
    misc = np.zeros(4)
    state = (np.array([steady.speed_rpm]), arrays.generator_state, arrays.excitation_state, arrays.outputs,
             arrays.work, misc)
    python = lambda f: getattr(f, "py_func", f)  # noqa: E731  (one-off calls; plain functions with NUMBA_DISABLE_JIT)
    misc[M_XBUS] = python(_bus_deviation)(scal, *params[5:], 0.0)
    status = python(_network_and_field)(scal, *params[1:5], arrays.generator_state, arrays.excitation_state,
                                        arrays.outputs, misc, 0.0, 0.0, dt_s)
    if status != 0:
        raise InputError(f"generator network at t = 0: {STATUS_TEXT[status]}")
    first = np.zeros(len(SIGNALS))
    python(subtransient_record)(params, state, first)

    def failure():
        if misc[M_STATUS] == 0.0:
            return ""
        return (f"sub-transient generator failed at t = {misc[M_TIME]:.6g} s: {STATUS_TEXT[int(misc[M_STATUS])]} "
                f"(grid.kind = {grid.kind!r})")

    def error_after(time_s, signals):
        return failure()

    def summary_after(time_s, signals):
        """Frequency recovery after the scenario's first load change (paper 001 section 4: 9.6 s after the 10 %
        step), band +-0.05 Hz (the European grid's standard frequency range; the paper states none)."""
        out = {}
        first_change = float(schedules.load_times_s[0]) if schedules.load_times_s.size else math.inf
        if math.isfinite(first_change) and "frequency_hz" in signals and time_s.size > 1 and not failure():
            rec = frequency_recovery_time(time_s, signals["frequency_hz"], event_time_s=first_change,
                                          rated_frequency_hz=grid.frequency_hz, band_hz=0.05)
            out = {"frequency_recovery_time_s": rec if math.isfinite(rec) else None,
                   "frequency_recovery_band_hz": 0.05, "frequency_event_time_s": first_change,
                   "frequency_recovery": ("never left the band" if math.isnan(rec) else
                                          "still outside the band at the end" if math.isinf(rec) else "recovered"),
                   "min_frequency_hz": float(np.min(signals["frequency_hz"])),
                   "max_frequency_hz": float(np.max(signals["frequency_hz"]))}
        return out

    summary = {"generator_model": "subtransient", "grid_kind": grid.kind,
               "initial_field_voltage_pu": arrays.field_voltage_pu,
               "initial_terminal_voltage_pu": float(first[0]),
               "generator_steady_max_residual": max(abs(v) for v in arrays.steady.residuals.values())}
    return CompiledPart(kind="shaft", name="subtransient",
                        functions={"speed": subtransient_speed, "step": subtransient_shaft_step,
                                   "record": subtransient_record, "power": subtransient_electrical_power,
                                   "grid_frequency": subtransient_grid_frequency},
                        params=params, state=state, signals=SIGNALS,
                        hooks=PartHooks(summary=summary, initial_signals=tuple(first), failure=failure,
                                        error_after=error_after, summary_after=summary_after,
                                        warnings_after=lambda signals: list(warnings)))


def rating_check(plant, schedules) -> list[str]:
    """A warning when the scenario loads the generator above its rated active power, ``rated_mva x power_factor``
    (MW): the largest of the initial load and the scheduled loads, as fractions of ``turbine.rated_power_mw``. The
    run goes on (a machine may carry more for a while); the warning names the keys to check."""
    gen = plant.generator.subtransient
    rated_active_mw = gen.rated_mva * gen.power_factor
    loads = [float(schedules.initial_load), *np.asarray(schedules.load_values, dtype=float).tolist()]
    largest_mw = max(loads) * plant.turbine.rated_power_mw
    if largest_mw <= rated_active_mw * (1.0 + 1e-9):
        return []
    return [f"the scenario loads the generator with {largest_mw:.4g} MW, above its rated active power "
            f"generator.rated_mva x generator.power_factor = {gen.rated_mva:g} x {gen.power_factor:g} = "
            f"{rated_active_mw:.4g} MW: check the machine's rating against turbine.rated_power_mw = "
            f"{plant.turbine.rated_power_mw:g} MW and the scenario's load"]


#: omega_n dt of the electromechanical mode above which the run is refused / warned (the rotor-angle pair is
#: semi-implicit Euler: stable up to omega_n dt = 2; its frequency error is about (omega_n dt)^2 / 24, 4 % at 1)
OMEGA_DT_REFUSE, OMEGA_DT_WARN = 1.0, 0.3


def electromechanical_step_check(plant, arrays, dt_s: float, schedules) -> list[str]:
    """On an infinite bus with the breaker closed: the electromechanical mode omega_n = sqrt(omega_b K_s (S/P_r) /
    Ta) (K_s of the classical E'q-behind-X'd model,
    :func:`simulate.components.electrical.standalone.transient_synchronizing_torque`) against the step. Refuses
    omega_n dt > :data:`OMEGA_DT_REFUSE` (InputError naming the keys), warns above :data:`OMEGA_DT_WARN`; returns the
    warnings."""
    from hillchart.errors import InputError
    from simulate.components.electrical.generator import P_OMEGA_B
    from simulate.components.electrical.standalone import transient_synchronizing_torque

    grid = plant.grid
    if grid.kind != "infinite-bus" or arrays.breaker == 0.0 or schedules.speed_held:
        return []
    gen = plant.generator.subtransient
    k_s = transient_synchronizing_torque(gen, grid, arrays.steady)
    if k_s <= 0.0:
        raise InputError(f"the initial point on the infinite bus is beyond the transient stability limit "
                         f"(synchronizing torque {k_s:.3g} pu/rad <= 0): lower the power or grid.x_line_pu")
    omega_n = math.sqrt(arrays.generator_params[P_OMEGA_B] * k_s * arrays.generator_params[P_TORQUE_RATIO]
                        / plant.generator.inertia_time_s)
    product = omega_n * dt_s
    text = (f"time step dt = {dt_s:.4g} s against the electromechanical mode on the infinite bus (omega_n = "
            f"{omega_n:.3g} rad/s, period {2 * math.pi / omega_n:.3g} s): omega_n dt = {product:.3g}")
    if product > OMEGA_DT_REFUSE:
        raise InputError(f"{text} > {OMEGA_DT_REFUSE} (allowed dt <= {OMEGA_DT_REFUSE / omega_n:.3g} s); set "
                         f"solver.dt_s (or penstock.reaches) smaller, or check grid.x_line_pu and "
                         f"generator.inertia_time_s")
    if product > OMEGA_DT_WARN:
        return [f"{text} > {OMEGA_DT_WARN}: the mode's frequency is off by about {100 * product ** 2 / 24:.2g} %"]
    return []


def time_scales(plant, schedules) -> list:
    """The sub-transient machine's fastest modes (T''d = T''d0 X''d/X'd, T''q = T''q0 X''q/Xq), its transient
    constant T'd = T'd0 X'd/Xd and the excitation filter, all sub-stepped within the MOC step; and the inertia time
    Ta unless the speed is held (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gen = plant.generator.subtransient
    out = [TimeScale("generator sub-transient d-axis time T''d = T''d0 X''d/X'd (generator.td0_st_s)",
                     gen.td0_st_s * gen.xd_st / gen.xd_t),
           TimeScale("generator sub-transient q-axis time T''q = T''q0 X''q/Xq (generator.tq0_st_s)",
                     gen.tq0_st_s * gen.xq_st / gen.xq),
           TimeScale("generator transient time T'd = T'd0 X'd/Xd (generator.td0_t_s)", gen.td0_t_s * gen.xd_t / gen.xd)]
    if plant.excitation.filter_s > 0.0:
        out.append(TimeScale("excitation.filter_s (T_f)", plant.excitation.filter_s))
    if not schedules.speed_held:
        out.append(TimeScale("generator.inertia_time_s (Ta)", plant.generator.inertia_time_s, coupled=True))
    return out
