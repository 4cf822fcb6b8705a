"""The generator on its own: the standard short-circuit and field-step tests, the unit (generator, excitation, rotor)
without the hydraulics, and reference solutions (the classical short-circuit envelope, frequency recovery,
synchronizing torque)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.validation import check_number
from simulate.components.electrical.generator import (
    GEN_OUTPUTS,
    GEN_PARAMS,
    GEN_STATE,
    O_ID,
    O_IQ,
    O_PE,
    O_QE,
    O_TE,
    O_VT,
    P_OMEGA_B,
    P_SUBSTEP,
    P_TORQUE_RATIO,
    S_DELTA,
    S_ED_ST,
    S_EQ_ST,
    S_EQ_T,
    STATUS_TEXT,
    ElectricalArrays,
    ElectricalConfig,
    GeneratorSteadyState,
    GridConfig,
    SubtransientGeneratorConfig,
    compile_electrical,
    electrical_from_dict,
    generator_derivatives,
    generator_parameters,
    generator_step,
    initial_generator_state,
    load_electrical,
    network_solution,
)

# ----------------------------------------------------------------------------------------------------------------
# classical short-circuit envelope
# ----------------------------------------------------------------------------------------------------------------


def classical_short_circuit_current(gen: SubtransientGeneratorConfig, voltage_pu: float, time_s) -> np.ndarray:
    """Symmetrical short-circuit current envelope from open circuit at voltage E (textbook formula):

    ``|i| = E [1/Xd + (1/X'd - 1/Xd) e^(-t/T'd) + (1/X''d - 1/X'd) e^(-t/T''d)]``,
    ``T'd = T'd0 X'd/Xd``, ``T''d = T''d0 X''d/X'd`` (the approximations that assume T''d0 << T'd0).

    Examples
    --------
    >>> g = SubtransientGeneratorConfig(xd=0.768, xd_t=0.249, xd_st=0.187, xq=0.512, xq_st=0.189, td0_t_s=7.88,
    ...                                 td0_st_s=0.049, tq0_st_s=0.0283, rated_mva=250.0, power_factor=0.9)
    >>> [round(float(v), 4) for v in classical_short_circuit_current(g, 1.0, [0.0, 1e3])]   # E/X''d, E/Xd
    [5.3476, 1.3021]
    """
    t = np.asarray(time_s, dtype=float)
    td_t = gen.td0_t_s * gen.xd_t / gen.xd
    td_st = gen.td0_st_s * gen.xd_st / gen.xd_t
    return voltage_pu * (1.0 / gen.xd + (1.0 / gen.xd_t - 1.0 / gen.xd) * np.exp(-t / td_t)
                         + (1.0 / gen.xd_st - 1.0 / gen.xd_t) * np.exp(-t / td_st))


def frequency_recovery_time(time_s, frequency_hz, *, event_time_s: float, rated_frequency_hz: float = 50.0,
                            band_hz: float = 0.05) -> float:
    """Time after ``event_time_s`` from which the frequency stays within ``rated +- band_hz`` to the end of the
    series (paper 001 section 4: "recovered within 9.6 s back to 50 Hz", band not stated). Default band: 50 mHz,
    the standard frequency range of the European grid. ``nan`` when it never leaves the band; ``inf`` when it is
    still outside at the end.

    Examples
    --------
    >>> t = np.linspace(0.0, 60.0, 6001)
    >>> f = 50.0 - 0.5 * np.exp(-(t - 10.0) / 4.0) * (t >= 10.0)       # -0.5 Hz, recovering with 4 s
    >>> round(frequency_recovery_time(t, f, event_time_s=10.0), 2)     # 4 ln(0.5/0.05) = 9.21, next sample
    9.22
    """
    t = np.asarray(time_s, dtype=float)
    f = np.asarray(frequency_hz, dtype=float)
    if t.shape != f.shape or t.ndim != 1 or t.size < 2:
        raise InputError(f"time_s and frequency_hz must be 1-D of the same length >= 2, got {t.shape}, {f.shape}")
    check_number("recovery.band_hz", band_hz, low=0.0, high=10.0, low_open=True)
    after = t >= event_time_s
    outside = after & (np.abs(f - rated_frequency_hz) > band_hz)
    if not np.any(outside):
        return float("nan")
    last = int(np.flatnonzero(outside)[-1])
    if last == t.size - 1:
        return float("inf")
    return float(t[last + 1] - event_time_s)


# ----------------------------------------------------------------------------------------------------------------
# standalone drivers (speed prescribed)
# ----------------------------------------------------------------------------------------------------------------

#: Columns of a standalone run (the ``timeseries.csv`` extra columns of the sub-transient model).
RUN_COLUMNS = ("time_s", "terminal_voltage_pu", "current_d_pu", "current_q_pu", "field_voltage_pu",
               "electrical_power_pu", "eq_t_pu", "eq_st_pu", "ed_st_pu", "frequency_hz")


@dataclass(frozen=True, eq=False)
class GeneratorRun:
    """Series of a standalone generator run, one row per step (row 0: the initial state).

    ``columns`` maps :data:`RUN_COLUMNS` (plus ``reactive_power_pu``, ``electrical_torque_pu``, ``delta_rad``) to
    arrays; ``steady`` is the initial :class:`GeneratorSteadyState`.
    """

    columns: dict
    steady: GeneratorSteadyState
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def to_csv(self, path) -> None:
        names = list(self.columns)
        np.savetxt(path, np.column_stack([self.columns[n] for n in names]), delimiter=",",
                   header=",".join(names), comments="", fmt="%.12g")


def simulate_generator(gen: SubtransientGeneratorConfig, grid: GridConfig, *, t_end_s: float, dt_s: float,
                       steady: GeneratorSteadyState, excitation=None, voltage_setpoint_pu: float | None = None,
                       speed_dev: float = 0.0, fault_time_s: float | None = None,
                       field_step: tuple[float, float] | None = None, load_step: tuple[float, float] | None = None,
                       breaker_open_time_s: float | None = None, jit: bool = True) -> GeneratorRun:
    """Run the generator alone at a constant per-unit speed deviation ``speed_dev``.

    Per step k (the order the plant loop uses, see the README): inputs at t_k; outputs of state k
    (:func:`network_solution`); field voltage for [t_k, t_k+1) from the excitation
    (:func:`simulate.components.control.excitation.excitation_step`, on V_k) or held at the steady value
    (+ ``field_step`` = (time_s, delta_pu) when reached); :func:`generator_step` to t_k+1.

    Parameters
    ----------
    excitation : simulate.components.control.excitation.ExcitationConfig or None
        None holds the field voltage (the standard short-circuit and field-step tests).
    voltage_setpoint_pu : float, optional
        Overrides ``excitation.voltage_setpoint_pu``.
    fault_time_s : float, optional
        Three-phase terminal fault from this time on.
    load_step : (time_s, load_scale), optional
        Island load multiplied by ``load_scale`` from ``time_s`` on.
    breaker_open_time_s : float, optional
        Breaker opens (currents to zero).
    jit : bool
        False runs the plain-Python versions (``.py_func``) of every jitted function (for the compiled-equals-Python
        check).
    """
    from simulate.components.control.excitation import excitation_parameters, excitation_step, initial_excitation_state

    check_number("run.t_end_s", t_end_s, low=0.0, high=1e5, low_open=True)
    check_number("run.dt_s", dt_s, low=0.0, high=1.0, low_open=True)
    n = int(round(t_end_s / dt_s))
    if n < 1:
        raise InputError(f"run.t_end_s = {t_end_s} is shorter than one step dt_s = {dt_s}")
    net, step = (network_solution, generator_step) if jit else (network_solution.py_func, generator_step.py_func)
    exc_step = excitation_step if jit else excitation_step.py_func
    p = steady.params
    state = steady.state.copy()
    efd = steady.field_voltage_pu
    if excitation is not None:
        ep = excitation_parameters(excitation, voltage_setpoint_pu=voltage_setpoint_pu)
        es = initial_excitation_state(excitation, efd)
    f_n = p[P_OMEGA_B] / (2.0 * math.pi)
    names = RUN_COLUMNS + ("reactive_power_pu", "electrical_torque_pu", "delta_rad")
    cols = {name: np.zeros(n + 1) for name in names}
    out = np.zeros(8)
    work = np.zeros(28)
    eps = 1e-9 * dt_s
    breaker0 = 1.0 if steady.breaker_closed else 0.0
    for k in range(n + 1):
        t = k * dt_s
        fault = 1.0 if fault_time_s is not None and t >= fault_time_s - eps else 0.0
        scale = load_step[1] if load_step is not None and t >= load_step[0] - eps else 1.0
        breaker = 0.0 if breaker_open_time_s is not None and t >= breaker_open_time_s - eps else breaker0
        status = net(p, state, speed_dev, breaker, scale, fault, out)
        if status != 0:
            raise NumericalError(f"generator network at t = {t:.6g} s: {STATUS_TEXT[status]}")
        if excitation is not None:
            efd = exc_step(ep, es, out[O_VT], dt_s)
        elif field_step is not None and t >= field_step[0] - eps:
            efd = steady.field_voltage_pu + field_step[1]
        for name, value in (("time_s", t), ("terminal_voltage_pu", out[O_VT]), ("current_d_pu", out[O_ID]),
                            ("current_q_pu", out[O_IQ]), ("field_voltage_pu", efd),
                            ("electrical_power_pu", out[O_PE]), ("eq_t_pu", state[S_EQ_T]),
                            ("eq_st_pu", state[S_EQ_ST]), ("ed_st_pu", state[S_ED_ST]),
                            ("frequency_hz", f_n * (1.0 + speed_dev)), ("reactive_power_pu", out[O_QE]),
                            ("electrical_torque_pu", out[O_TE]), ("delta_rad", state[S_DELTA])):
            cols[name][k] = value
        if k == n:
            break
        status = step(p, state, speed_dev, efd, breaker, scale, fault, dt_s, work)
        if status != 0:
            raise NumericalError(f"generator step at t = {t:.6g} s: {STATUS_TEXT[status]}")
    return GeneratorRun(columns=cols, steady=steady, meta={"dt_s": dt_s, "compiled": jit,
                                                           "substeps": int(math.ceil(dt_s / p[P_SUBSTEP] - 1e-9))})


def simulate_unit(gen: SubtransientGeneratorConfig, grid: GridConfig, *, t_end_s: float, dt_s: float,
                  steady: GeneratorSteadyState, inertia_time_s: float, excitation=None,
                  torque_step: tuple[float, float] | None = None, load_step: tuple[float, float] | None = None,
                  fault_window: tuple[float, float] | None = None, jit: bool = True) -> GeneratorRun:
    """Generator + rotor with a prescribed mechanical torque: the swing equation of
    :mod:`simulate.components.shaft.rotor` with the generator's air-gap torque as its load (how the plant loop couples
    the two; see the README).

    The mechanical torque (turbine torque base P_r/omega_r) equals the steady electrical torque, then steps by
    ``torque_step = (time_s, delta_pu)``. ``inertia_time_s`` Ta on the turbine base (``steady`` must have been built
    with ``turbine_rated_power_mw``). ``fault_window = (on_s, off_s)``: three-phase terminal fault, cleared at
    ``off_s`` (the machine stays connected). Extra columns ``speed_dev``, ``current_d_pu``, ``current_q_pu``.

    Per step k: (1) :func:`network_solution` at (state_k, x_k) -> Te_k, V_k; (2) field voltage from
    :func:`simulate.components.control.excitation.excitation_step` on V_k (or held); (3)
    ``x_k+1 = rotor_step(x_k, m_t, Te_k * torque_base_ratio, 0, Ta, dt)`` (self-regulation 0: the load's frequency
    dependence is in the grid);
    (4) :func:`generator_step` (state_k -> state_k+1 at x_k).
    """
    from simulate.components.control.excitation import excitation_parameters, excitation_step, initial_excitation_state
    from simulate.components.shaft.rotor import rotor_step

    check_number("run.t_end_s", t_end_s, low=0.0, high=1e5, low_open=True)
    check_number("run.dt_s", dt_s, low=0.0, high=1.0, low_open=True)
    check_number("generator.inertia_time_s", inertia_time_s, low=0.0, high=100.0, low_open=True)
    n = int(round(t_end_s / dt_s))
    net, step = (network_solution, generator_step) if jit else (network_solution.py_func, generator_step.py_func)
    exc_step = excitation_step if jit else excitation_step.py_func
    rotor = rotor_step if jit else rotor_step.py_func
    p = steady.params
    ratio = p[P_TORQUE_RATIO]
    state = steady.state.copy()
    efd = steady.field_voltage_pu
    if excitation is not None:
        ep = excitation_parameters(excitation)
        es = initial_excitation_state(excitation, efd)
    m_mech0 = steady.outputs["electrical_torque_pu"] * ratio
    names = ("time_s", "speed_dev", "electrical_torque_pu", "terminal_voltage_pu", "field_voltage_pu",
             "delta_rad", "eq_t_pu", "eq_st_pu", "ed_st_pu", "current_d_pu", "current_q_pu")
    cols = {name: np.zeros(n + 1) for name in names}
    out, work = np.zeros(8), np.zeros(28)
    x = 0.0
    eps = 1e-9 * dt_s
    breaker = 1.0 if steady.breaker_closed else 0.0
    for k in range(n + 1):
        t = k * dt_s
        scale = load_step[1] if load_step is not None and t >= load_step[0] - eps else 1.0
        m_mech = m_mech0 + (torque_step[1] if torque_step is not None and t >= torque_step[0] - eps else 0.0)
        fault = 1.0 if fault_window is not None and fault_window[0] - eps <= t < fault_window[1] - eps else 0.0
        status = net(p, state, x, breaker, scale, fault, out)  # (1)
        if status != 0:
            raise NumericalError(f"generator network at t = {t:.6g} s: {STATUS_TEXT[status]}")
        if excitation is not None:
            efd = exc_step(ep, es, out[O_VT], dt_s)  # (2)
        for name, value in (("time_s", t), ("speed_dev", x), ("electrical_torque_pu", out[O_TE]),
                            ("terminal_voltage_pu", out[O_VT]), ("field_voltage_pu", efd),
                            ("delta_rad", state[S_DELTA]), ("eq_t_pu", state[S_EQ_T]),
                            ("eq_st_pu", state[S_EQ_ST]), ("ed_st_pu", state[S_ED_ST]),
                            ("current_d_pu", out[O_ID]), ("current_q_pu", out[O_IQ])):
            cols[name][k] = value
        if k == n:
            break
        x_next = rotor(x, m_mech, out[O_TE] * ratio, 0.0, inertia_time_s, dt_s)  # (3)
        status = step(p, state, x_next, efd, breaker, scale, fault, dt_s, work)  # (4)
        if status != 0:
            raise NumericalError(f"generator step at t = {t:.6g} s: {STATUS_TEXT[status]}")
        x = x_next
    return GeneratorRun(columns=cols, steady=steady, meta={"dt_s": dt_s, "compiled": jit})


def transient_synchronizing_torque(gen: SubtransientGeneratorConfig, grid: GridConfig,
                                   steady: GeneratorSteadyState) -> float:
    """dTe/d(delta) (machine base per rad) of a machine on an infinite bus with E'q held and the sub-transient
    circuits settled (E''q = E'q - (X'd - X''d) Id, E''d = (Xq - X''q) Iq): the classical transient model, E'q
    behind X'd on the d axis and Xq on the q axis::

        Te = E'q Vb sin(d) / (X'd + x) + Vb^2 / 2 (1/(Xq + x) - 1/(X'd + x)) sin(2 d)

    The electromechanical mode of the rotor is then omega_n = sqrt(omega_b K_s (S/P_r) / Ta) (rad/s).
    """
    if grid.kind != "infinite-bus":
        raise InputError("transient_synchronizing_torque needs grid.kind = 'infinite-bus'")
    x, vb = grid.x_line_pu, grid.bus_voltage_pu
    d = steady.state[S_DELTA]
    eq_t = steady.state[S_EQ_T]
    return (eq_t * vb * math.cos(d) / (gen.xd_t + x)
            + vb ** 2 * (1.0 / (gen.xq + x) - 1.0 / (gen.xd_t + x)) * math.cos(2.0 * d))


def short_circuit_test(gen: SubtransientGeneratorConfig, *, voltage_pu: float = 1.0, event_time_s: float = 0.1,
                       t_end_s: float = 5.0, dt_s: float = 1e-3, frequency_hz: float = 50.0,
                       jit: bool = True) -> GeneratorRun:
    """The standard short-circuit test: open circuit at rated speed and ``voltage_pu``, three-phase fault at the
    terminals at ``event_time_s``, speed and field voltage held."""
    grid = GridConfig(kind="island", frequency_hz=frequency_hz)
    steady = initial_generator_state(gen, grid, airgap_power_pu=0.0, voltage_pu=voltage_pu, breaker_closed=False)
    return simulate_generator(gen, grid, t_end_s=t_end_s, dt_s=dt_s, steady=steady, fault_time_s=event_time_s,
                              jit=jit)


def field_step_test(gen: SubtransientGeneratorConfig, *, field_step_pu: float = 0.1, voltage_pu: float = 1.0,
                    event_time_s: float = 1.0, t_end_s: float = 40.0, dt_s: float = 0.01,
                    frequency_hz: float = 50.0, jit: bool = True) -> GeneratorRun:
    """Open circuit at rated speed and ``voltage_pu``; the field voltage steps by ``field_step_pu`` at
    ``event_time_s``. The terminal voltage then rises with T'd0 (and a T''d0 lag): V = V0 + dv [1 - (T'd0
    e^(-t/T'd0) - T''d0 e^(-t/T''d0)) / (T'd0 - T''d0)]."""
    check_number("scenario.field_step_pu", field_step_pu, low=-1.0, high=1.0)
    grid = GridConfig(kind="island", frequency_hz=frequency_hz)
    steady = initial_generator_state(gen, grid, airgap_power_pu=0.0, voltage_pu=voltage_pu, breaker_closed=False)
    return simulate_generator(gen, grid, t_end_s=t_end_s, dt_s=dt_s, steady=steady,
                              field_step=(event_time_s, field_step_pu), jit=jit)


__all__ = ["SubtransientGeneratorConfig", "GridConfig", "ElectricalConfig", "ElectricalArrays", "compile_electrical",
           "GeneratorSteadyState", "GeneratorRun",
           "GEN_PARAMS", "GEN_STATE", "GEN_OUTPUTS", "RUN_COLUMNS", "STATUS_TEXT", "electrical_from_dict",
           "load_electrical", "network_solution", "generator_derivatives", "generator_step", "generator_parameters",
           "initial_generator_state", "classical_short_circuit_current", "simulate_generator", "simulate_unit",
           "transient_synchronizing_torque", "frequency_recovery_time", "short_circuit_test",
           "field_step_test"]
