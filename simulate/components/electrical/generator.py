"""Synchronous generator, sub-transient d-q model (paper 001 section 3, eq. (10), Table 1), and its grid.

Per unit on the machine base (``rated_mva``, rated voltage, rated frequency); time in seconds. Generator convention:
currents flow out of the machine. The q axis leads the d axis; a phasor A (bus frame) has the d-q components
``A_d + j A_q = A exp(-j (delta - pi/2))``, delta the angle of the q axis ahead of the infinite bus.

States (:data:`GEN_STATE`): ``E'q, E''q, E''d`` of eq. (10) and the rotor angle ``delta`` (rad, used by the
infinite bus only; in an island it just integrates the frequency deviation)::

    T'd0  dE'q/dt  = v_f - E'q  - Id (Xd  - X'd)          eq. (10), first row  (v_f: field voltage, "v")
    T''d0 dE''q/dt = E'q - E''q - Id (X'd - X''d)         eq. (10), second row
    T''q0 dE''d/dt = -E''d      + Iq (Xq  - X''q)         eq. (10), third row
    d delta/dt     = omega_b (x - x_bus)                   (x: per-unit speed deviation, omega_b = 2 pi f_n)

x_bus is the infinite bus's per-unit frequency deviation (0 at rated frequency; the scenario kind
``grid-frequency-step`` steps it): delta is the machine's angle against the bus, which turns at omega_b (1 + x_bus).
The line reactance and the machine's reactances stay those of rated frequency (as the stator equations below).

Stator transients are neglected (the paper's third-order model) and the stator voltage equations use rated speed::

    Vd = E''d - Ra Id + X''q Iq,   Vq = E''q - Ra Iq - X''d Id
    Te = E''d Id + E''q Iq + (X''q - X''d) Id Iq = Vd Id + Vq Iq + Ra (Id^2 + Iq^2)   (air-gap torque = power)

The network closes the currents algebraically (:func:`network_solution`): a three-phase fault at the terminals
(V = 0), an open breaker (I = 0), an island load (I = Y V, admittance from constant impedance or constant power,
with a frequency dependence) or an infinite bus behind a line reactance (``V = V_bus + j x_line I``).

Everything the time loop calls is a pure numba function (``cache=True``) on float arrays: parameters from
:func:`generator_parameters` (layout :data:`GEN_PARAMS`), the state vector (layout :data:`GEN_STATE`), inputs as
scalars. One step is :func:`generator_step` (classical RK4 in sub-steps no longer than a quarter of the shortest
short-circuit time constant, the network solved at every stage). RK4 is written by hand because it must run inside
the compiled loop (scipy's integrators cannot be called from numba); the tests check it against
``scipy.integrate.solve_ivp`` (Radau) and the closed-form solutions.

The small Python drivers of :mod:`simulate.components.electrical.standalone` (``simulate_generator``,
``short_circuit_test``, ``field_step_test``) run the generator (and the excitation of
:mod:`simulate.components.control.excitation`) alone at a prescribed speed."""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.validation import check_number
from simulate.components.parameters import parameter, read_section, read_toml, validate_parameters

GRID_KINDS = ("island", "infinite-bus")
LOAD_MODELS = ("impedance", "power")
ISLAND, INFINITE_BUS = 0, 1

#: Layout of the generator parameter vector (machine base per unit, s, rad/s).
GEN_PARAMS = ("xd", "xd_t", "xd_st", "xq", "xq_st", "td0_t_s", "td0_st_s", "tq0_st_s", "ra", "grid_kind",
              "x_line_pu", "bus_voltage_pu", "load_g0_pu", "load_b0_pu", "load_v0_pu", "load_exp_p", "load_exp_q",
              "frequency_p", "frequency_q", "omega_base_rad_s", "max_substep_s", "torque_base_ratio",
              "max_iterations", "tolerance")
(P_XD, P_XD_T, P_XD_ST, P_XQ, P_XQ_ST, P_TD0_T, P_TD0_ST, P_TQ0_ST, P_RA, P_GRID, P_XLINE, P_VBUS, P_G0, P_B0, P_V0,
 P_NP, P_NQ, P_KPF, P_KQF, P_OMEGA_B, P_SUBSTEP, P_TORQUE_RATIO, P_MAXIT, P_TOL) = range(len(GEN_PARAMS))

#: Layout of the generator state vector.
GEN_STATE = ("eq_t_pu", "eq_st_pu", "ed_st_pu", "delta_rad")
S_EQ_T, S_EQ_ST, S_ED_ST, S_DELTA = range(4)

#: Layout of the output vector written by :func:`network_solution` / :func:`generator_outputs`.
GEN_OUTPUTS = ("vd_pu", "vq_pu", "id_pu", "iq_pu", "terminal_voltage_pu", "electrical_power_pu",
               "electrical_torque_pu", "reactive_power_pu")
O_VD, O_VQ, O_ID, O_IQ, O_VT, O_PE, O_TE, O_QE = range(8)

#: Status codes of the jitted functions (0 = ok).
STATUS_TEXT = {0: "ok", 1: "network matrix singular (generator + grid impedance determinant ~ 0)",
               2: "constant-power load: voltage iteration did not converge (load beyond the voltage-stability "
                  "limit?)", 3: "terminal voltage collapsed to zero under a constant-power load",
               4: "non-finite generator state"}

#: Keys of the ``[generator]`` section owned by the rotor (swing) part of the plant, accepted and ignored here.
ROTOR_KEYS = ("model", "inertia_time_s", "self_regulation")


# ----------------------------------------------------------------------------------------------------------------
# configuration
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SubtransientGeneratorConfig:
    """Sub-transient salient-pole machine of paper 001 eq. (10) (per unit on ``rated_mva``, times in s).

    ``xd, xd_t, xd_st``: X_d, X'_d, X''_d; ``xq, xq_st``: X_q, X''_q; ``td0_t_s, td0_st_s, tq0_st_s``: T'_d0, T''_d0,
    T''_q0 (open circuit); ``ra`` stator resistance (default 0, as Table 1); ``rated_mva`` the machine base;
    ``power_factor`` the rated power factor (rated active power = rated_mva * power_factor).
    Physical ordering is enforced: 0 < X''d < X'd < Xd, 0 < X''q < Xq, 0 < T''d0 < T'd0.
    """

    xd: float = parameter(unit="pu", low=0.0, low_open=True, high=10.0, description="synchronous reactance X_d")
    xd_t: float = parameter(unit="pu", low=0.0, low_open=True, high=10.0, description="transient reactance X'_d")
    xd_st: float = parameter(unit="pu", low=0.0, low_open=True, high=10.0,
                             description="sub-transient reactance X''_d")
    xq: float = parameter(unit="pu", low=0.0, low_open=True, high=10.0, description="synchronous reactance X_q")
    xq_st: float = parameter(unit="pu", low=0.0, low_open=True, high=10.0,
                             description="sub-transient reactance X''_q")
    td0_t_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                               description="open-circuit transient time constant T'_d0")
    td0_st_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                description="open-circuit sub-transient time constant T''_d0")
    tq0_st_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                description="open-circuit sub-transient time constant T''_q0")
    rated_mva: float = parameter(unit="MVA", low=0.0, low_open=True, high=5000.0, description="the machine base")
    power_factor: float = parameter(unit="1", low=0.0, low_open=True, high=1.0, description="rated power factor")
    ra: float = parameter(0.0, unit="pu", low=0.0, high=0.1, description="stator resistance")

    def __post_init__(self):
        validate_parameters("generator", self)
        for small, large in (("xd_st", "xd_t"), ("xd_t", "xd"), ("xq_st", "xq"), ("td0_st_s", "td0_t_s")):
            if not getattr(self, small) < getattr(self, large):
                raise InputError(f"generator.{small} must be < generator.{large} = {getattr(self, large)!r} "
                                 f"(sub-transient < transient < synchronous), got {getattr(self, small)!r}")

    @property
    def rated_power_mw(self) -> float:
        """rated_mva * power_factor, MW."""
        return self.rated_mva * self.power_factor

    @property
    def shortest_time_constant_s(self) -> float:
        """min(T''d, T''q) with T''d = T''d0 X''d/X'd, T''q = T''q0 X''q/Xq: the fastest mode (terminal short)."""
        return min(self.td0_st_s * self.xd_st / self.xd_t, self.tq0_st_s * self.xq_st / self.xq)


@dataclass(frozen=True)
class GridConfig:
    """What the generator feeds (``[grid]``).

    ``kind = "island"``: a local load that takes the initial power at the initial voltage, ``load_model``
    ``"impedance"`` (P, Q proportional to V^2) or ``"power"`` (P, Q independent of V), power factor
    ``load_power_factor`` (lagging), frequency dependence P = P0 (1 + frequency_p x), Q = Q0 (1 + frequency_q x)
    with x the per-unit speed deviation. The rotor sees the flux-linkage torque psi_d Iq - psi_q Id, which with the
    stator at rated speed is the air-gap power in per unit, so frequency_p is directly the load's torque
    self-regulation (the swing model's e_g = 1 at the initial load is frequency_p = 1).
    ``kind = "infinite-bus"``: ``x_line_pu`` line reactance (machine base, > 0) to a bus of ``bus_voltage_pu`` at
    rated frequency (the scenario kind ``grid-frequency-step`` steps the bus's frequency). ``frequency_hz``: rated
    frequency (omega_b = 2 pi f_n).
    Keys of the other kind are rejected.
    """

    kind: str = parameter(unit="", choices=GRID_KINDS, description="what the generator feeds")
    frequency_hz: float = parameter(50.0, unit="Hz", low=1.0, high=1000.0, description="rated frequency f_n")
    load_model: str | None = parameter(None, unit="", choices=LOAD_MODELS,
                                       description="island load: impedance (default) or constant power")
    load_power_factor: float | None = parameter(None, unit="1", low=0.0, low_open=True, high=1.0,
                                                description="island load's power factor, lagging (default 1)")
    frequency_p: float | None = parameter(None, unit="pu/pu", low=-10.0, high=10.0,
                                          description="island load's active-power frequency dependence (default 0)")
    frequency_q: float | None = parameter(None, unit="pu/pu", low=-10.0, high=10.0,
                                          description="island load's reactive-power frequency dependence (default 0)")
    x_line_pu: float | None = parameter(None, unit="pu", low=0.0, low_open=True, high=5.0,
                                        description="infinite bus: line reactance, machine base")
    bus_voltage_pu: float | None = parameter(None, unit="pu", low=0.5, high=1.5,
                                             description="infinite bus: bus voltage")

    ISLAND_KEYS = ("load_model", "load_power_factor", "frequency_p", "frequency_q")
    BUS_KEYS = ("x_line_pu", "bus_voltage_pu")

    def __post_init__(self):
        validate_parameters("grid", self)
        own, other = (self.ISLAND_KEYS, self.BUS_KEYS) if self.kind == "island" else (self.BUS_KEYS,
                                                                                     self.ISLAND_KEYS)
        for key in other:
            if getattr(self, key) is not None:
                raise InputError(f"grid.{key} is not used by grid.kind = {self.kind!r}; allowed keys: kind, "
                                 f"frequency_hz, {', '.join(own)}")
        if self.kind != "island":
            for key in self.BUS_KEYS:
                if getattr(self, key) is None:
                    raise InputError(f"grid.{key} is required for grid.kind = 'infinite-bus'")

    # defaults of the island keys (None in the record means "not given")
    @property
    def island_load_model(self) -> str:
        return self.load_model or "impedance"

    @property
    def island_power_factor(self) -> float:
        return 1.0 if self.load_power_factor is None else float(self.load_power_factor)

    @property
    def island_frequency_p(self) -> float:
        return 1.0 if self.frequency_p is None else float(self.frequency_p)

    @property
    def island_frequency_q(self) -> float:
        return 0.0 if self.frequency_q is None else float(self.frequency_q)


@dataclass(frozen=True)
class ElectricalConfig:
    """The three electrical sections of a plant file: ``[generator]`` (sub-transient keys), ``[excitation]``,
    ``[grid]``."""

    generator: SubtransientGeneratorConfig
    excitation: Any  # simulate.components.control.excitation.ExcitationConfig
    grid: GridConfig


def electrical_from_dict(raw: dict) -> ElectricalConfig:
    """Build the electrical sections from a parsed TOML dictionary (other sections are ignored; the rotor keys of
    ``[generator]`` (:data:`ROTOR_KEYS`) are accepted; ``generator.model`` must be ``"subtransient"`` if given).
    """
    from simulate.components.control.excitation import ExcitationConfig

    if not isinstance(raw, dict):
        raise InputError(f"plant file must be a table of sections, got {raw!r}")
    for name in ("generator", "excitation", "grid"):
        if name not in raw:
            raise InputError(f"missing section [{name}]; a sub-transient generator needs [generator], [excitation] "
                             f"and [grid]")
    gen_raw = raw["generator"]
    if isinstance(gen_raw, dict) and gen_raw.get("model", "subtransient") != "subtransient":
        raise InputError(f"generator.model must be \"subtransient\" for the sub-transient keys, got "
                         f"{gen_raw.get('model')!r} (allowed: swing, subtransient)")
    generator = read_section("generator", SubtransientGeneratorConfig, gen_raw, ignore=ROTOR_KEYS)
    excitation = read_section("excitation", ExcitationConfig, raw["excitation"])
    grid_raw = raw["grid"]
    grid = read_section("grid", GridConfig, grid_raw)
    return ElectricalConfig(generator=generator, excitation=excitation, grid=grid)


def load_electrical(path: str | Path) -> ElectricalConfig:
    """Read ``[generator]``, ``[excitation]`` and ``[grid]`` from a TOML file (e.g.
    ``data_synthetic/generator_table1.toml``).

    Examples
    --------
    >>> import importlib.resources as ir
    >>> e = load_electrical(ir.files("data_synthetic") / "generator_table1.toml")
    >>> e.generator.xd, e.generator.td0_t_s, e.grid.kind
    (0.768, 7.88, 'island')
    """
    raw, _ = read_toml(path, "generator file")
    return electrical_from_dict(raw)


# ----------------------------------------------------------------------------------------------------------------
# jitted physics
# ----------------------------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _solve_currents(p, e_d, e_q, zn11, zn12, zn21, zn22, vs_d, vs_q, out):
    """Stator (Vd = E''d - Ra Id + X''q Iq, Vq = E''q - Ra Iq - X''d Id) against V = Zn I + Vs; fills ``out``."""
    ra, xd_st, xq_st = p[P_RA], p[P_XD_ST], p[P_XQ_ST]
    a11, a12 = ra + zn11, -xq_st + zn12
    a21, a22 = xd_st + zn21, ra + zn22
    det = a11 * a22 - a12 * a21
    if abs(det) < 1e-12:
        return 1
    r1, r2 = e_d - vs_d, e_q - vs_q
    i_d = (r1 * a22 - a12 * r2) / det
    i_q = (a11 * r2 - a21 * r1) / det
    v_d = e_d - ra * i_d + xq_st * i_q
    v_q = e_q - ra * i_q - xd_st * i_d
    out[O_VD], out[O_VQ], out[O_ID], out[O_IQ] = v_d, v_q, i_d, i_q
    return 0


@numba.njit(cache=True)
def network_solution(p, state, speed_dev, breaker, load_scale, fault, out):
    """Currents, terminal voltage, powers and air-gap torque of the present state (layout :data:`GEN_OUTPUTS`).

    Parameters
    ----------
    p : float array (:data:`GEN_PARAMS`)
    state : float array (:data:`GEN_STATE`)
    speed_dev : float
        Per-unit speed deviation x (frequency dependence of the island load).
    breaker : float
        1 closed, 0 open (no current unless ``fault``).
    load_scale : float
        Island load as a multiple of the initial load (1 = initial; 0 = no load); ignored on the infinite bus.
    fault : float
        1 = three-phase short circuit at the terminals (V = 0), else 0.
    out : float array (8,)

    Returns
    -------
    int
        Status (0 ok; see :data:`STATUS_TEXT`).
    """
    e_d, e_q = state[S_ED_ST], state[S_EQ_ST]
    status = 0
    if fault > 0.5:
        status = _solve_currents(p, e_d, e_q, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, out)
    elif breaker < 0.5 or (p[P_GRID] == ISLAND and load_scale <= 0.0):
        out[O_VD], out[O_VQ], out[O_ID], out[O_IQ] = e_d, e_q, 0.0, 0.0  # open circuit: V = E''
    elif p[P_GRID] == INFINITE_BUS:
        x, vb, delta = p[P_XLINE], p[P_VBUS], state[S_DELTA]
        # V = V_bus + j x I in the rotor frame: Vd = Vb sin(delta) - x Iq, Vq = Vb cos(delta) + x Id
        status = _solve_currents(p, e_d, e_q, 0.0, -x, x, 0.0, vb * math.sin(delta), vb * math.cos(delta), out)
    else:
        # island load I = Y V, Y = G + jB with P = s P0 (V/V0)^np (1 + kpf x), Q = s Q0 (V/V0)^nq (1 + kqf x)
        v0, n_p, n_q = p[P_V0], p[P_NP], p[P_NQ]
        fp = load_scale * (1.0 + p[P_KPF] * speed_dev)
        fq = load_scale * (1.0 + p[P_KQF] * speed_dev)
        v = v0
        converged = False
        for _ in range(int(p[P_MAXIT])):
            ratio = v / v0
            g = p[P_G0] * fp * ratio ** (n_p - 2.0)
            b = p[P_B0] * fq * ratio ** (n_q - 2.0)
            y2 = g * g + b * b
            if y2 == 0.0:
                out[O_VD], out[O_VQ], out[O_ID], out[O_IQ] = e_d, e_q, 0.0, 0.0
                converged = True
                break
            # V = Y^-1 I: [[g, b], [-b, g]] / (g^2 + b^2)
            status = _solve_currents(p, e_d, e_q, g / y2, b / y2, -b / y2, g / y2, 0.0, 0.0, out)
            if status != 0:
                return status
            v_new = math.sqrt(out[O_VD] ** 2 + out[O_VQ] ** 2)
            if v_new < 1e-6:
                return 3
            if abs(v_new - v) <= p[P_TOL] or (n_p == 2.0 and n_q == 2.0):
                converged = True
                break
            v = v_new
        if not converged:
            return 2
    if status != 0:
        return status
    v_d, v_q, i_d, i_q = out[O_VD], out[O_VQ], out[O_ID], out[O_IQ]
    out[O_VT] = math.sqrt(v_d * v_d + v_q * v_q)
    out[O_PE] = v_d * i_d + v_q * i_q
    out[O_QE] = v_q * i_d - v_d * i_q
    out[O_TE] = out[O_PE] + p[P_RA] * (i_d * i_d + i_q * i_q)  # air-gap torque (power at rated speed)
    return 0


@numba.njit(cache=True)
def generator_derivatives(p, state, field_voltage, speed_dev, i_d, i_q, deriv, bus_speed_dev=0.0):
    """d/dt of the state, paper 001 eq. (10) and d delta/dt = omega_b (x - x_bus); fills ``deriv`` (4,).

    ``bus_speed_dev``: the infinite bus's per-unit frequency deviation x_bus (0: the bus at rated frequency)."""
    deriv[S_EQ_T] = (field_voltage - state[S_EQ_T] - i_d * (p[P_XD] - p[P_XD_T])) / p[P_TD0_T]  # eq. (10)
    deriv[S_EQ_ST] = (state[S_EQ_T] - state[S_EQ_ST] - i_d * (p[P_XD_T] - p[P_XD_ST])) / p[P_TD0_ST]  # eq. (10)
    deriv[S_ED_ST] = (-state[S_ED_ST] + i_q * (p[P_XQ] - p[P_XQ_ST])) / p[P_TQ0_ST]  # eq. (10)
    deriv[S_DELTA] = p[P_OMEGA_B] * (speed_dev - bus_speed_dev)  # the angle against the bus


@numba.njit(cache=True)
def generator_step(p, state, speed_dev, field_voltage, breaker, load_scale, fault, dt_s, work, bus_speed_dev=0.0):
    """Advance ``state`` in place by ``dt_s`` (inputs held over the step); RK4 in equal sub-steps.

    ``work`` is a scratch array of at least 28 floats (no allocation in the loop); ``bus_speed_dev`` the infinite
    bus's per-unit frequency deviation x_bus over the step (:func:`generator_derivatives`). Returns the status (0 ok).
    """
    n_sub = max(1, int(math.ceil(dt_s / p[P_SUBSTEP] - 1e-9)))
    h = dt_s / n_sub
    out = work[0:8]
    k1, k2, k3, k4 = work[8:12], work[12:16], work[16:20], work[20:24]
    tmp = work[24:28]
    for _ in range(n_sub):
        st = network_solution(p, state, speed_dev, breaker, load_scale, fault, out)
        if st != 0:
            return st
        generator_derivatives(p, state, field_voltage, speed_dev, out[O_ID], out[O_IQ], k1, bus_speed_dev)
        for i in range(4):
            tmp[i] = state[i] + 0.5 * h * k1[i]
        st = network_solution(p, tmp, speed_dev, breaker, load_scale, fault, out)
        if st != 0:
            return st
        generator_derivatives(p, tmp, field_voltage, speed_dev, out[O_ID], out[O_IQ], k2, bus_speed_dev)
        for i in range(4):
            tmp[i] = state[i] + 0.5 * h * k2[i]
        st = network_solution(p, tmp, speed_dev, breaker, load_scale, fault, out)
        if st != 0:
            return st
        generator_derivatives(p, tmp, field_voltage, speed_dev, out[O_ID], out[O_IQ], k3, bus_speed_dev)
        for i in range(4):
            tmp[i] = state[i] + h * k3[i]
        st = network_solution(p, tmp, speed_dev, breaker, load_scale, fault, out)
        if st != 0:
            return st
        generator_derivatives(p, tmp, field_voltage, speed_dev, out[O_ID], out[O_IQ], k4, bus_speed_dev)
        for i in range(4):
            state[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            if not math.isfinite(state[i]):
                return 4
    return 0


# ----------------------------------------------------------------------------------------------------------------
# parameters and steady state
# ----------------------------------------------------------------------------------------------------------------


def generator_parameters(gen: SubtransientGeneratorConfig, grid: GridConfig, *, load_g0_pu: float = 0.0,
                         load_b0_pu: float = 0.0, load_v0_pu: float = 1.0,
                         turbine_rated_power_mw: float | None = None) -> np.ndarray:
    """The float vector (layout :data:`GEN_PARAMS`) for the jitted functions.

    ``load_*`` come from the steady state (:func:`initial_generator_state`); ``torque_base_ratio`` =
    rated_mva / P_r converts the air-gap torque from the machine base to the turbine torque base P_r/omega_r of the
    rotor equation (1 when ``turbine_rated_power_mw`` is None).
    """
    p = np.zeros(len(GEN_PARAMS))
    p[[P_XD, P_XD_T, P_XD_ST, P_XQ, P_XQ_ST, P_TD0_T, P_TD0_ST, P_TQ0_ST, P_RA]] = (
        gen.xd, gen.xd_t, gen.xd_st, gen.xq, gen.xq_st, gen.td0_t_s, gen.td0_st_s, gen.tq0_st_s, gen.ra)
    p[P_GRID] = ISLAND if grid.kind == "island" else INFINITE_BUS
    if grid.kind == "infinite-bus":
        p[P_XLINE], p[P_VBUS] = grid.x_line_pu, grid.bus_voltage_pu
    else:
        p[P_NP] = p[P_NQ] = 2.0 if grid.island_load_model == "impedance" else 0.0
        p[P_KPF], p[P_KQF] = grid.island_frequency_p, grid.island_frequency_q
    p[P_G0], p[P_B0], p[P_V0] = load_g0_pu, load_b0_pu, load_v0_pu
    p[P_OMEGA_B] = 2.0 * math.pi * grid.frequency_hz
    p[P_SUBSTEP] = 0.25 * gen.shortest_time_constant_s  # RK4 step x fastest eigenvalue <= 0.25
    p[P_TORQUE_RATIO] = 1.0 if turbine_rated_power_mw is None else gen.rated_mva / turbine_rated_power_mw
    p[P_MAXIT], p[P_TOL] = 100.0, 1e-13
    return p


@dataclass(frozen=True)
class GeneratorSteadyState:
    """A verified steady state of generator + grid (machine-base per unit).

    ``state`` (:data:`GEN_STATE`), ``field_voltage_pu``, ``outputs`` (:data:`GEN_OUTPUTS`), ``params`` (the vector
    for the loop, with the island load fixed from this point), ``residuals`` {equation: value} all below 1e-9.
    """

    state: np.ndarray
    field_voltage_pu: float
    outputs: dict
    params: np.ndarray
    breaker_closed: bool = True
    residuals: dict = field(default_factory=dict)


def _dq(phasor: complex, delta: float) -> tuple[float, float]:
    """d and q components of a bus-frame phasor for a q axis at angle delta."""
    z = phasor * cmath.exp(-1j * (delta - math.pi / 2))
    return z.real, z.imag


def initial_generator_state(gen: SubtransientGeneratorConfig, grid: GridConfig, *, airgap_power_pu: float,
                            voltage_pu: float, breaker_closed: bool = True,
                            turbine_rated_power_mw: float | None = None, tolerance: float = 1e-9
                            ) -> GeneratorSteadyState:
    """Steady state at rated speed delivering ``airgap_power_pu`` (machine base; = turbine power / rated_mva) at
    terminal voltage ``voltage_pu``, with every residual of eq. (10) and the network checked below ``tolerance``.

    Island: the load takes the terminal power at ``load_power_factor``; its admittance at this point is stored in
    the parameters. Infinite bus: the terminal voltage magnitude is ``voltage_pu`` and the bus angle follows from
    P = V Vb sin(theta)/x_line (too much power for the line is an :class:`InputError`). ``breaker_closed=False`` (or
    zero power in an island): open circuit, E'q = E''q = V, E''d = 0, field voltage V.

    Raises
    ------
    InputError
        Infeasible point (power beyond the line's limit, negative power).
    NumericalError
        A residual above ``tolerance`` (names the equation and its value).
    """
    check_number("initial point.airgap_power_pu", airgap_power_pu, low=0.0, high=3.0)
    check_number("initial point.voltage_pu", voltage_pu, low=0.5, high=1.5)
    v0 = float(voltage_pu)
    ra = gen.ra
    open_circuit = not breaker_closed or (grid.kind == "island" and airgap_power_pu == 0.0)
    g0 = b0 = 0.0
    delta_bus = 0.0  # angle of the terminal voltage ahead of the bus (0 in an island)
    if open_circuit:
        current = 0j
        p_term = q_term = 0.0
    else:
        # terminal power P with P + Ra |I|^2 = airgap power: |I| depends on P (and Q): fixed point, contraction Ra
        p_term = airgap_power_pu
        for _ in range(200):
            if grid.kind == "island":
                pf = grid.island_power_factor
                q_term = p_term * math.tan(math.acos(pf))
            else:
                x, vb = grid.x_line_pu, grid.bus_voltage_pu
                s = p_term * x / (v0 * vb)
                if abs(s) >= 1.0:
                    raise InputError(f"grid.x_line_pu = {x!r}: the line cannot carry {p_term:.4g} pu at terminal "
                                     f"voltage {v0} and bus voltage {vb} (needs P x / (V Vb) < 1, got {s:.4g})")
                delta_bus = math.asin(s)
                q_term = (v0 * v0 - v0 * vb * math.cos(delta_bus)) / x
            i_mag2 = (p_term ** 2 + q_term ** 2) / v0 ** 2
            new = airgap_power_pu - ra * i_mag2
            if abs(new - p_term) < 1e-15:
                break
            p_term = new
        if p_term < 0:
            raise InputError(f"airgap_power_pu = {airgap_power_pu} is below the stator loss: no steady state")
        current = (p_term - 1j * q_term) / (v0 * cmath.exp(-1j * delta_bus))  # I = S* / V*
        if grid.kind == "island":
            g0, b0 = p_term / v0 ** 2, -q_term / v0 ** 2  # Y = S* / |V|^2
    v_ph = v0 * cmath.exp(1j * delta_bus)
    e_q_axis = v_ph + complex(ra, gen.xq) * current  # E_Q = V + (Ra + j Xq) I lies on the q axis
    # open circuit: the q axis on the terminal voltage (V = E''q), no load angle
    delta = cmath.phase(e_q_axis) if abs(current) > 0 else delta_bus
    v_d, v_q = _dq(v_ph, delta)
    i_d, i_q = _dq(current, delta)
    ed_st = (gen.xq - gen.xq_st) * i_q  # eq. (10) third row at rest
    eq_st = v_q + ra * i_q + gen.xd_st * i_d  # stator q equation
    eq_t = eq_st + (gen.xd_t - gen.xd_st) * i_d  # eq. (10) second row at rest
    efd = eq_t + (gen.xd - gen.xd_t) * i_d  # eq. (10) first row at rest
    state = np.array([eq_t, eq_st, ed_st, delta])
    params = generator_parameters(gen, grid, load_g0_pu=g0, load_b0_pu=b0, load_v0_pu=v0,
                                  turbine_rated_power_mw=turbine_rated_power_mw)
    out = np.zeros(8)
    status = network_solution(params, state, 0.0, 1.0 if breaker_closed else 0.0, 1.0, 0.0, out)
    if status != 0:
        raise NumericalError(f"generator steady state: network solution failed: {STATUS_TEXT[status]}")
    deriv = np.zeros(4)
    generator_derivatives(params, state, efd, 0.0, out[O_ID], out[O_IQ], deriv)
    residuals = {"eq10_dEq_t_dt": deriv[0] * gen.td0_t_s, "eq10_dEq_st_dt": deriv[1] * gen.td0_st_s,
                 "eq10_dEd_st_dt": deriv[2] * gen.tq0_st_s,
                 "airgap_power": out[O_TE] - (0.0 if open_circuit else airgap_power_pu),
                 "terminal_voltage": out[O_VT] - v0,
                 "current_d": out[O_ID] - i_d, "current_q": out[O_IQ] - i_q}
    worst = max(residuals, key=lambda k: abs(residuals[k]))
    if not abs(residuals[worst]) < tolerance:
        raise NumericalError(f"generator steady state: residual of {worst} is {residuals[worst]:.3g} "
                             f"(tolerance {tolerance:g})")
    outputs = dict(zip(GEN_OUTPUTS, (float(v) for v in out)))
    return GeneratorSteadyState(state=state, field_voltage_pu=float(efd), outputs=outputs, params=params,
                                breaker_closed=bool(breaker_closed),
                                residuals={k: float(v) for k, v in residuals.items()})


@dataclass(frozen=True, eq=False)
class ElectricalArrays:
    """Everything the plant loop needs from the electrical sections, compiled at a verified steady state.

    ``generator_params`` (:data:`GEN_PARAMS`), ``generator_state`` (:data:`GEN_STATE`, mutated by the loop),
    ``excitation_params`` / ``excitation_state`` (:mod:`simulate.components.control.excitation` layouts),
    ``field_voltage_pu`` (steady field), ``outputs`` (8 floats, :data:`GEN_OUTPUTS`) and ``work`` (28 floats) scratch
    for the jitted steps, ``breaker`` (1.0 / 0.0 initial), ``steady`` (the :class:`GeneratorSteadyState`).
    """

    generator_params: np.ndarray
    generator_state: np.ndarray
    excitation_params: np.ndarray
    excitation_state: np.ndarray
    field_voltage_pu: float
    outputs: np.ndarray
    work: np.ndarray
    breaker: float
    steady: GeneratorSteadyState


def compile_electrical(electrical: ElectricalConfig, *, turbine_power_mw: float, turbine_rated_power_mw: float,
                       breaker_closed: bool = True) -> ElectricalArrays:
    """Compile ``[generator]``, ``[excitation]``, ``[grid]`` at the turbine's steady state for the plant loop.

    The rotor is in equilibrium at rated speed, so the air-gap power equals the turbine power:
    ``airgap_power_pu = turbine_power_mw / rated_mva``. ``breaker_closed=False`` (no-load kinds): open circuit at
    the voltage set point. The terminal voltage is the excitation's set point.

    Raises
    ------
    InputError
        Turbine power above 1.5 x the machine rating, a field voltage outside the excitation limits, an infeasible
        infinite-bus point.
    NumericalError
        A steady-state residual above 1e-9.

    Examples
    --------
    >>> import importlib.resources as ir
    >>> e = load_electrical(ir.files("data_synthetic") / "generator_table1.toml")
    >>> arrays = compile_electrical(e, turbine_power_mw=225.0, turbine_rated_power_mw=225.0)
    >>> round(float(arrays.steady.outputs["electrical_torque_pu"] * arrays.generator_params[P_TORQUE_RATIO]), 12)
    1.0
    """
    from simulate.components.control.excitation import excitation_parameters, initial_excitation_state

    gen, exc = electrical.generator, electrical.excitation
    check_number("turbine.rated_power_mw", turbine_rated_power_mw, low=0.0, high=5000.0, low_open=True)
    check_number("initial point.turbine_power_mw", turbine_power_mw, low=0.0, high=1.5 * gen.rated_mva)
    steady = initial_generator_state(gen, electrical.grid, airgap_power_pu=turbine_power_mw / gen.rated_mva,
                                     voltage_pu=exc.voltage_setpoint_pu, breaker_closed=breaker_closed,
                                     turbine_rated_power_mw=turbine_rated_power_mw)
    return ElectricalArrays(generator_params=steady.params, generator_state=steady.state.copy(),
                            excitation_params=excitation_parameters(exc),
                            excitation_state=initial_excitation_state(exc, steady.field_voltage_pu),
                            field_voltage_pu=steady.field_voltage_pu, outputs=np.zeros(len(GEN_OUTPUTS)),
                            work=np.zeros(28), breaker=1.0 if breaker_closed else 0.0, steady=steady)
