"""Sub-transient generator (paper 001 eq. (10), Table 1), grid and voltage control: analytic checks, cross-checks,
garbage input."""

from __future__ import annotations

import importlib.resources as ir
import math
import tomllib

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

from hillchart.errors import InputError, NumericalError
from simulate.components.control.excitation import (
    ExcitationConfig,
    excitation_parameters,
    excitation_step,
    initial_excitation_state,
)
from simulate.components.electrical.generator import (
    GEN_OUTPUTS,
    O_ID,
    O_IQ,
    O_PE,
    O_TE,
    O_VT,
    GridConfig,
    SubtransientGeneratorConfig,
    electrical_from_dict,
    generator_derivatives,
    initial_generator_state,
    load_electrical,
    network_solution,
)
from simulate.components.electrical.standalone import (
    classical_short_circuit_current,
    field_step_test,
    short_circuit_test,
    simulate_generator,
)

TABLE1 = ir.files("data_synthetic") / "generator_table1.toml"
ELEC = load_electrical(TABLE1)
GEN = ELEC.generator
EXC = ELEC.excitation
ISLAND = ELEC.grid
BUS = GridConfig(kind="infinite-bus", x_line_pu=0.3, bus_voltage_pu=1.0)


def test_table1_ships_as_example_file():
    g = GEN
    assert (g.xd, g.xd_t, g.xd_st, g.xq, g.xq_st) == (0.768, 0.249, 0.187, 0.512, 0.189)
    assert (g.td0_t_s, g.td0_st_s, g.tq0_st_s, g.ra) == (7.88, 0.049, 0.0283, 0.0)
    assert g.rated_power_mw == pytest.approx(225.0)  # matches the example plant


# ---------------------------------------------------------------------------------------------------------------
# short circuit
# ---------------------------------------------------------------------------------------------------------------


def _exact_short_circuit(gen, e0, t):
    """Closed form of eq. (10) after a terminal fault from open circuit (Ra = 0, field held): Id = E''q / X''d,
    the q axis stays at rest; the d axis is the linear system below, solved by the matrix exponential."""
    a = np.array([[-1.0 / gen.td0_t_s, -(gen.xd - gen.xd_t) / (gen.xd_st * gen.td0_t_s)],
                  [1.0 / gen.td0_st_s, -(1.0 + (gen.xd_t - gen.xd_st) / gen.xd_st) / gen.td0_st_s]])
    b = np.array([e0 / gen.td0_t_s, 0.0])  # constant field voltage v = E0
    m = np.zeros((3, 3))
    m[:2, :2], m[:2, 2] = a, b
    step = scipy.linalg.expm(m * (t[1] - t[0]))  # uniform samples: one exponential, powers of it
    states = [np.array([e0, e0, 1.0])]
    for _ in t[1:]:
        states.append(step @ states[-1])
    return np.array(states)[:, 1] / gen.xd_st, np.linalg.eigvals(a)


def test_short_circuit_current_matches_closed_form_and_classical_envelope():
    run = short_circuit_test(GEN, voltage_pu=1.0, event_time_s=0.1, t_end_s=5.0, dt_s=1e-3)
    t, i_d, i_q = run["time_s"], run["current_d_pu"], run["current_q_pu"]
    before, after = t < 0.1 - 1e-9, t >= 0.1 - 1e-9
    assert np.all(np.hypot(i_d, i_q)[before] == 0.0)  # open circuit before the fault
    assert np.max(np.abs(i_q)) < 1e-12  # from open circuit the q axis is never excited (Ra = 0)
    current = np.hypot(i_d, i_q)[after]
    tau = t[after] - 0.1
    exact, eig = _exact_short_circuit(GEN, 1.0, tau)
    # RK4 (sub-step 0.9 ms here: 1 ms / 2) against the closed form: integrator error only
    assert np.max(np.abs(current - exact)) < 1e-6
    assert current[0] == pytest.approx(1.0 / GEN.xd_st, rel=1e-12)  # E / X''d at the fault instant
    # the classical envelope uses T'd = T'd0 X'd/Xd, T''d = T''d0 X''d/X'd, which approximate the eigenvalues of
    # the 2x2 system above (their product is exact, their sum is off by (Xd/X'd - 1)/T'd0 = 0.26 1/s of 27 1/s):
    # with Table 1 the curves differ by at most 0.5 % of the initial current (measured 0.48 %), so 1 % is the
    # bound; a wrong reactance or time constant in eq. (10) moves it by more (see the next assertion)
    classical = classical_short_circuit_current(GEN, 1.0, tau)
    assert np.max(np.abs(current - classical)) / classical[0] < 0.01
    td_t, td_st = GEN.td0_t_s * GEN.xd_t / GEN.xd, GEN.td0_st_s * GEN.xd_st / GEN.xd_t
    assert sorted(-1.0 / np.real(eig)) == pytest.approx([td_st, td_t], rel=0.03)  # time constants within 3 %
    wrong = classical_short_circuit_current(SubtransientGeneratorConfig(
        **{**GEN.__dict__, "td0_st_s": 0.9 * GEN.td0_st_s}), 1.0, tau)  # T''d0 10 % off
    assert np.max(np.abs(current - wrong)) / classical[0] > 0.01  # ... would fail the 1 % bound
    assert current[-1] == pytest.approx(exact[-1], rel=1e-6)


def test_rk4_matches_scipy_radau_on_a_loaded_island_with_a_load_step():
    steady = initial_generator_state(GEN, ISLAND, airgap_power_pu=0.8, voltage_pu=1.0)
    dt = 0.01
    run = simulate_generator(GEN, ISLAND, t_end_s=3.0, dt_s=dt, steady=steady, load_step=(0.0, 1.3),
                             speed_dev=0.002)
    p, efd = steady.params, steady.field_voltage_pu
    out = np.zeros(8)

    def rhs(_t, y):
        deriv = np.zeros(4)
        network_solution(p, y, 0.002, 1.0, 1.3, 0.0, out)
        generator_derivatives(p, y, efd, 0.002, out[O_ID], out[O_IQ], deriv)
        return deriv

    sol = scipy.integrate.solve_ivp(rhs, (0.0, 3.0), steady.state, method="Radau", rtol=1e-11, atol=1e-12,
                                    t_eval=run["time_s"])
    # independent integrator (implicit, error-controlled) vs RK4 with sub-steps of 0.25 x the fastest time constant
    assert np.max(np.abs(sol.y[0] - run["eq_t_pu"])) < 1e-8
    assert np.max(np.abs(sol.y[1] - run["eq_st_pu"])) < 1e-7
    assert np.max(np.abs(sol.y[2] - run["ed_st_pu"])) < 1e-7
    assert np.max(np.abs(sol.y[3] - run["delta_rad"])) < 1e-9  # omega_b x t exactly


# ---------------------------------------------------------------------------------------------------------------
# field step
# ---------------------------------------------------------------------------------------------------------------


def test_field_step_terminal_voltage_rises_with_td0_t():
    step, t0 = 0.1, 1.0
    run = field_step_test(GEN, field_step_pu=step, event_time_s=t0, t_end_s=40.0, dt_s=0.01)
    t, v = run["time_s"], run["terminal_voltage_pu"]
    after = t >= t0 - 1e-9
    s = t[after] - t0
    a, b = GEN.td0_t_s, GEN.td0_st_s
    exact = 1.0 + step * (1.0 - (a * np.exp(-s / a) - b * np.exp(-s / b)) / (a - b))  # cascade of two lags
    assert np.max(np.abs(v[after] - exact)) < 1e-8
    # time constant from a log-linear fit of the remaining deviation, after five T''d0 (the fast lag has gone):
    # the slope is -1/T'd0 exactly; 0.1 % allows for the fit's end effects only
    window = (s > 5 * b) & (s < 3 * a)
    slope = np.polyfit(s[window], np.log(1.0 + step - v[after][window]), 1)[0]
    assert -1.0 / slope == pytest.approx(GEN.td0_t_s, rel=1e-3)
    # the 63 % time is T'd0 plus the T''d0 lag (+ one sample of detection)
    t63 = s[np.argmax(v[after] - 1.0 >= (1 - math.exp(-1)) * step)]
    assert abs(t63 - (a + b)) < 0.02
    assert np.all(v[t < t0] == 1.0)


# ---------------------------------------------------------------------------------------------------------------
# steady state and power balance
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("grid", [ISLAND, GridConfig(kind="island", load_model="power", load_power_factor=0.85,
                                                     frequency_p=1.0, frequency_q=0.5), BUS],
                         ids=["island-impedance", "island-power", "infinite-bus"])
@pytest.mark.parametrize("ra", [0.0, 0.004])
def test_steady_state_holds_and_balances_power(grid, ra):
    gen = SubtransientGeneratorConfig(**{**GEN.__dict__, "ra": ra})
    steady = initial_generator_state(gen, grid, airgap_power_pu=0.85, voltage_pu=1.02, turbine_rated_power_mw=225.0)
    assert max(abs(v) for v in steady.residuals.values()) < 1e-9
    run = simulate_generator(gen, grid, t_end_s=20.0, dt_s=0.02, steady=steady, excitation=EXC,
                             voltage_setpoint_pu=1.02)
    for name, index in (("eq_t_pu", 0), ("eq_st_pu", 1), ("ed_st_pu", 2)):
        assert np.max(np.abs(run[name] - steady.state[index])) < 1e-9  # a verified steady state stays put
    o = steady.outputs
    i2 = o["id_pu"] ** 2 + o["iq_pu"] ** 2
    # air-gap power = terminal power + stator loss; equals the requested (turbine) power
    assert o["electrical_torque_pu"] == pytest.approx(o["electrical_power_pu"] + ra * i2, abs=1e-12)
    assert o["electrical_torque_pu"] == pytest.approx(0.85, abs=1e-12)
    assert o["terminal_voltage_pu"] == pytest.approx(1.02, abs=1e-12)
    # turbine torque base: 0.85 pu of 250 MVA = 212.5 MW = 0.9444 of P_r = 225 MW
    assert o["electrical_torque_pu"] * steady.params[21] == pytest.approx(212.5 / 225.0, rel=1e-12)
    if grid.kind == "island":
        # the load consumes the terminal power: P = G V^2, Q = -B V^2 at the stored admittance
        g0, b0 = steady.params[12], steady.params[13]
        assert g0 * 1.02 ** 2 == pytest.approx(o["electrical_power_pu"], rel=1e-12)
        assert -b0 * 1.02 ** 2 == pytest.approx(o["reactive_power_pu"], rel=1e-12)
        pf = o["electrical_power_pu"] / math.hypot(o["electrical_power_pu"], o["reactive_power_pu"])
        assert pf == pytest.approx(grid.island_power_factor, abs=1e-12)
    else:
        # lossless line: the bus receives the terminal power; V Vb sin(theta)/x = P
        delta = steady.state[3]
        p_bus = 1.0 * math.sin(delta) * o["id_pu"] + 1.0 * math.cos(delta) * o["iq_pu"]
        assert p_bus == pytest.approx(o["electrical_power_pu"], abs=1e-12)


def test_infeasible_infinite_bus_point_is_an_input_error():
    with pytest.raises(InputError, match="grid.x_line_pu = 2.0: the line cannot carry"):
        initial_generator_state(GEN, GridConfig(kind="infinite-bus", x_line_pu=2.0, bus_voltage_pu=1.0),
                                airgap_power_pu=0.9, voltage_pu=1.0)


# ---------------------------------------------------------------------------------------------------------------
# voltage control
# ---------------------------------------------------------------------------------------------------------------


def test_voltage_control_restores_the_setpoint_after_an_island_load_step():
    steady = initial_generator_state(GEN, ISLAND, airgap_power_pu=0.8, voltage_pu=1.0)
    held = simulate_generator(GEN, ISLAND, t_end_s=30.0, dt_s=0.01, steady=steady, load_step=(1.0, 1.1))
    ctrl = simulate_generator(GEN, ISLAND, t_end_s=30.0, dt_s=0.01, steady=steady, load_step=(1.0, 1.1),
                              excitation=EXC)
    v_held, v_ctrl = held["terminal_voltage_pu"], ctrl["terminal_voltage_pu"]
    # constant field: the heavier load pulls the voltage down and it stays down
    assert v_held[-1] < 0.97
    # PI: back to the set point (integral action), the field voltage higher than before
    assert abs(v_ctrl[-1] - 1.0) < 1e-4
    assert ctrl["field_voltage_pu"][-1] > steady.field_voltage_pu + 0.05
    assert np.min(v_ctrl) > np.min(v_held)


def test_anti_windup_leaves_the_limit_at_once():
    p = excitation_parameters(EXC)
    state = initial_excitation_state(EXC, 1.0)
    for _ in range(2000):  # 20 s of a large error: output saturated at field_max
        out = excitation_step(p, state, 0.7, 0.01)
    assert out == EXC.field_max_pu
    # the integral holds exactly the limit minus the proportional part: nothing stored beyond the limit
    assert state[1] == pytest.approx(EXC.field_max_pu - EXC.kp * state[0], abs=1e-12)
    # the voltage overshoots the set point: the output leaves the limit within the filter's settling (5 T_f)
    steps = 0
    while excitation_step(p, state, 1.05, 0.01) >= EXC.field_max_pu:
        steps += 1
    assert steps * 0.01 <= 5 * EXC.filter_s
    # without the clamp the integral would have grown by ki * 0.3 * 20 s = 60 pu and take seconds to unwind
    assert 20.0 * EXC.ki * 0.3 > 10 * EXC.field_max_pu


def test_initial_field_voltage_outside_the_limits_is_an_input_error():
    with pytest.raises(InputError, match=r"field voltage of 6 pu, outside \[excitation.field_min_pu"):
        initial_excitation_state(EXC, 6.0)


# ---------------------------------------------------------------------------------------------------------------
# compiled == Python
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("grid", [ISLAND, GridConfig(kind="island", load_model="power"), BUS],
                         ids=["impedance", "power", "bus"])
def test_compiled_equals_python(grid):
    steady = initial_generator_state(GEN, grid, airgap_power_pu=0.7, voltage_pu=1.0)
    kw = dict(t_end_s=2.0, dt_s=0.02, steady=steady, excitation=EXC, load_step=(0.5, 1.1), fault_time_s=1.5,
              speed_dev=0.001)
    fast = simulate_generator(GEN, grid, jit=True, **kw)
    slow = simulate_generator(GEN, grid, jit=False, **kw)
    for name in fast.columns:
        # same source, same operations: equal up to the compiler's floating-point contraction (measured 0 or 1 ulp)
        np.testing.assert_allclose(fast[name], slow[name], rtol=1e-12, atol=1e-12, err_msg=name)


def test_network_outputs_layout_is_the_documented_one():
    steady = initial_generator_state(GEN, ISLAND, airgap_power_pu=0.5, voltage_pu=1.0)
    out = np.zeros(len(GEN_OUTPUTS))
    assert network_solution(steady.params, steady.state, 0.0, 1.0, 1.0, 0.0, out) == 0
    assert out[O_VT] == pytest.approx(1.0, abs=1e-12) and out[O_PE] == pytest.approx(0.5, abs=1e-12)
    assert out[O_TE] == pytest.approx(0.5, abs=1e-12)


def test_constant_power_load_beyond_the_nose_is_reported_not_nan():
    grid = GridConfig(kind="island", load_model="power", load_power_factor=0.8)
    steady = initial_generator_state(GEN, grid, airgap_power_pu=0.9, voltage_pu=1.0)
    with pytest.raises(NumericalError, match="constant-power load|voltage collapsed|singular"):
        simulate_generator(GEN, grid, t_end_s=0.5, dt_s=0.01, steady=steady, load_step=(0.1, 8.0))


# ---------------------------------------------------------------------------------------------------------------
# garbage input, per section
# ---------------------------------------------------------------------------------------------------------------


@pytest.fixture()
def raw():
    return tomllib.loads(TABLE1.read_text())


@pytest.mark.parametrize("section, key, value, match", [
    ("generator", "xd", -0.7, r"generator.xd must be in \(0.0, 10.0\], got -0.7"),
    ("generator", "xd_t", 0.9, r"generator.xd_t must be < generator.xd = 0.768"),
    ("generator", "xd_st", 0.3, r"generator.xd_st must be < generator.xd_t = 0.249"),
    ("generator", "xq_st", 0.6, r"generator.xq_st must be < generator.xq"),
    ("generator", "td0_st_s", 8.0, r"generator.td0_st_s must be < generator.td0_t_s"),
    ("generator", "tq0_st_s", 0.0, r"generator.tq0_st_s must be in \(0.0, 100.0\]"),
    ("generator", "ra", 0.5, r"generator.ra must be in \[0.0, 0.1\], got 0.5"),
    ("generator", "rated_mva", "big", r"generator.rated_mva must be a number"),
    ("generator", "power_factor", 1.2, r"generator.power_factor must be in \(0.0, 1.0\]"),
    ("generator", "xq", float("nan"), r"generator.xq must be in"),
    ("generator", "model", "swing", r"generator.model must be \"subtransient\""),
    ("generator", "xdd", 1.0, r"unknown key generator.xdd; valid keys of \[generator\]"),
    ("excitation", "kp", -1.0, r"excitation.kp must be in \[0.0, 1000.0\], got -1.0"),
    ("excitation", "ki", True, r"excitation.ki must be a number"),
    ("excitation", "filter_s", -0.1, r"excitation.filter_s must be in \[0.0, 10.0\]"),
    ("excitation", "field_min_pu", 6.0, r"excitation.field_min_pu must be < excitation.field_max_pu = 5.0"),
    ("excitation", "voltage_setpoint_pu", 3.0, r"excitation.voltage_setpoint_pu must be in \[0.5, 1.5\]"),
    ("excitation", "gain", 1.0, r"unknown key excitation.gain"),
    ("grid", "kind", "microgrid", r"grid.kind must be one of island, infinite-bus; got 'microgrid'"),
    ("grid", "load_model", "zip", r"grid.load_model must be one of impedance, power"),
    ("grid", "load_power_factor", 0.0, r"grid.load_power_factor must be in \(0.0, 1.0\]"),
    ("grid", "frequency_p", 100.0, r"grid.frequency_p must be in \[-10.0, 10.0\]"),
    ("grid", "frequency_hz", 0.0, r"grid.frequency_hz must be in \[1.0, 1000.0\]"),
    ("grid", "x_line_pu", 0.3, r"grid.x_line_pu is not used by grid.kind = 'island'"),
])
def test_bad_electrical_sections_are_rejected(raw, section, key, value, match):
    raw[section][key] = value
    with pytest.raises(InputError, match=match):
        electrical_from_dict(raw)


@pytest.mark.parametrize("section, key, match", [
    ("generator", "xd", r"missing required key generator.xd"),
    ("excitation", "kp", r"missing required key excitation.kp"),
    ("grid", "kind", r"missing required key grid.kind"),
])
def test_missing_keys_are_named(raw, section, key, match):
    del raw[section][key]
    with pytest.raises(InputError, match=match):
        electrical_from_dict(raw)


@pytest.mark.parametrize("grid, match", [
    ({"kind": "infinite-bus", "x_line_pu": 0.3}, r"grid.bus_voltage_pu is required"),
    ({"kind": "infinite-bus", "x_line_pu": 0.0, "bus_voltage_pu": 1.0}, r"grid.x_line_pu must be in \(0.0, 5.0\]"),
    ({"kind": "infinite-bus", "x_line_pu": 0.3, "bus_voltage_pu": 1.0, "load_model": "power"},
     r"grid.load_model is not used by grid.kind = 'infinite-bus'"),
])
def test_bad_infinite_bus_sections_are_rejected(raw, grid, match):
    raw["grid"] = grid
    with pytest.raises(InputError, match=match):
        electrical_from_dict(raw)


def test_missing_section_and_unreadable_file(raw, tmp_path):
    del raw["excitation"]
    with pytest.raises(InputError, match=r"missing section \[excitation\]"):
        electrical_from_dict(raw)
    with pytest.raises(InputError, match="cannot read"):
        load_electrical(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[generator\n")
    with pytest.raises(InputError, match="is not valid TOML"):
        load_electrical(bad)


@pytest.mark.parametrize("kw, match", [
    ({"airgap_power_pu": -0.1, "voltage_pu": 1.0}, r"initial point.airgap_power_pu must be in \[0.0, 3.0\]"),
    ({"airgap_power_pu": 0.5, "voltage_pu": 0.1}, r"initial point.voltage_pu must be in \[0.5, 1.5\]"),
])
def test_bad_initial_point_is_rejected(kw, match):
    with pytest.raises(InputError, match=match):
        initial_generator_state(GEN, ISLAND, **kw)


def test_bad_run_settings_are_rejected():
    steady = initial_generator_state(GEN, ISLAND, airgap_power_pu=0.5, voltage_pu=1.0)
    with pytest.raises(InputError, match=r"run.dt_s must be in \(0.0, 1.0\]"):
        simulate_generator(GEN, ISLAND, t_end_s=1.0, dt_s=0.0, steady=steady)
    with pytest.raises(InputError, match=r"scenario.field_step_pu must be in \[-1.0, 1.0\]"):
        field_step_test(GEN, field_step_pu=5.0)


# ---------------------------------------------------------------------------------------------------------------
# generator + rotor (how the plant loop couples them)
# ---------------------------------------------------------------------------------------------------------------


def _mode(run):
    """Frequency (Hz) and damping ratio of the speed oscillation, from zero crossings and the peak decay."""
    t, x = run["time_s"], run["speed_dev"]
    m = t > 1.0
    crossings = t[m][np.where(np.diff(np.sign(x[m])) != 0)[0]]
    peaks = np.array([np.max(np.abs(x[(t > a) & (t < b)])) for a, b in zip(crossings[:-1], crossings[1:])])
    decay = np.polyfit(np.arange(peaks.size), np.log(peaks), 1)[0]  # log decrement per half period
    return 1.0 / (2.0 * np.mean(np.diff(crossings))), -decay / math.pi


def test_electromechanical_mode_on_an_infinite_bus():
    from simulate.components.electrical.standalone import simulate_unit, transient_synchronizing_torque

    steady = initial_generator_state(GEN, BUS, airgap_power_pu=0.8, voltage_pu=1.0, turbine_rated_power_mw=225.0)
    runs = {dt: simulate_unit(GEN, BUS, t_end_s=15.0, dt_s=dt, steady=steady, inertia_time_s=9.0,
                              torque_step=(0.5, 0.05)) for dt in (0.02, 0.002)}
    ks = transient_synchronizing_torque(GEN, BUS, steady)
    f_classical = math.sqrt(2 * math.pi * 50.0 * ks * steady.params[21] / 9.0) / (2 * math.pi)
    f, zeta = _mode(runs[0.002])
    # the classical transient model (E'q behind X'd, dampers settled) predicts the frequency; the damper circuits
    # of eq. (10) shift it slightly (measured 1.1448 vs 1.1431 Hz): 2 % bound
    assert f == pytest.approx(f_classical, rel=0.02)
    # the damper windings damp the mode (measured zeta 0.037). The loop order matters: the angle integrates with
    # the new speed x_k+1 (semi-implicit), so the damping does not depend on the step; with x_k (explicit Euler for
    # the pair) the step would add negative damping ~ omega^2 dt / (2 omega) = 2.6 % at dt = 0.02 s
    f2, zeta2 = _mode(runs[0.02])
    assert 0.02 < zeta < 0.06
    assert zeta2 == pytest.approx(zeta, rel=0.02) and f2 == pytest.approx(f, rel=0.005)
    # after the torque step the rotor returns to the bus frequency with a larger load angle
    x = runs[0.002]["speed_dev"]
    assert abs(x[-1]) < 0.05 * np.max(np.abs(x))
    assert runs[0.002]["delta_rad"][-1] > steady.state[3]


def test_terminal_fault_with_the_rotor_accelerates_it_by_the_whole_mechanical_torque():
    from simulate.components.electrical.standalone import simulate_unit

    steady = initial_generator_state(GEN, BUS, airgap_power_pu=0.8, voltage_pu=1.0, turbine_rated_power_mw=250.0)
    run = simulate_unit(GEN, BUS, t_end_s=1.2, dt_s=0.002, steady=steady, inertia_time_s=8.1,
                        fault_window=(1.0, 1.1))
    t, x = run["time_s"], run["speed_dev"]
    during = (t >= 1.0 - 1e-9) & (t < 1.1 - 1e-9)
    # V = 0 and Ra = 0: no electrical torque during the fault, so Ta dx/dt = m_t exactly (Euler is exact here)
    assert np.max(np.abs(run["electrical_torque_pu"][during])) < 1e-12
    k = int(round(1.1 / 0.002))
    assert x[k] - x[int(round(1.0 / 0.002))] == pytest.approx(0.8 * 0.1 / 8.1, rel=1e-9)
    # the fault current starts at |E''| / X'' of the loaded machine (about 5.5 pu; ANDES GENROU: 5.496)
    i0 = math.hypot(run["current_d_pu"][int(round(1.0 / 0.002))], run["current_q_pu"][int(round(1.0 / 0.002))])
    assert i0 == pytest.approx(math.hypot(steady.state[1] / GEN.xd_st, steady.state[2] / GEN.xq_st), rel=1e-12)


def test_compile_electrical_for_the_plant_loop():
    from simulate.components.electrical.generator import compile_electrical, network_solution

    arrays = compile_electrical(ELEC, turbine_power_mw=200.0, turbine_rated_power_mw=225.0)
    # the air-gap torque on the turbine base equals the turbine's: 200 MW of P_r = 225 MW at rated speed
    assert network_solution(arrays.generator_params, arrays.generator_state, 0.0, arrays.breaker, 1.0, 0.0,
                            arrays.outputs) == 0
    assert arrays.outputs[O_TE] * arrays.generator_params[21] == pytest.approx(200.0 / 225.0, rel=1e-12)
    assert arrays.outputs[O_VT] == pytest.approx(EXC.voltage_setpoint_pu, abs=1e-12)
    assert arrays.excitation_state[1] == arrays.field_voltage_pu  # the PI holds the steady field
    no_load = compile_electrical(ELEC, turbine_power_mw=0.0, turbine_rated_power_mw=225.0, breaker_closed=False)
    assert no_load.breaker == 0.0 and no_load.field_voltage_pu == pytest.approx(1.0)
    with pytest.raises(InputError, match=r"initial point.turbine_power_mw must be in \[0.0, 375.0\]"):
        compile_electrical(ELEC, turbine_power_mw=400.0, turbine_rated_power_mw=225.0)
    tight = ExcitationConfig(**{**EXC.__dict__, "field_max_pu": 1.2})  # rated point needs 1.49 pu
    with pytest.raises(InputError, match="outside \\[excitation.field_min_pu, excitation.field_max_pu\\]"):
        compile_electrical(type(ELEC)(generator=GEN, excitation=tight, grid=ISLAND), turbine_power_mw=225.0,
                           turbine_rated_power_mw=225.0)


def test_frequency_recovery_time_band():
    from simulate.components.electrical.standalone import frequency_recovery_time

    t = np.linspace(0.0, 60.0, 60001)
    f = 50.0 - 0.5 * np.exp(-(t - 10.0) / 4.0) * np.cos(0.5 * (t - 10.0)) * (t >= 10.0)
    rec = frequency_recovery_time(t, f, event_time_s=10.0, band_hz=0.05)
    # the last exit from the band: after it |f - 50| <= 0.05 Hz for good, and just before it was outside
    k = int(round((10.0 + rec) / 1e-3))
    assert np.all(np.abs(f[k:] - 50.0) <= 0.05) and abs(f[k - 1] - 50.0) > 0.05
    assert 4.0 * math.log(0.5 / 0.05) - 2.0 < rec < 4.0 * math.log(0.5 / 0.05) + 1e-3  # inside the envelope time
    assert math.isinf(frequency_recovery_time(t, f - 0.1, event_time_s=10.0))  # never back in the band
    assert math.isnan(frequency_recovery_time(t, np.full_like(t, 50.0), event_time_s=10.0))
    with pytest.raises(InputError, match=r"recovery.band_hz must be in \(0.0, 10.0\]"):
        frequency_recovery_time(t, f, event_time_s=10.0, band_hz=0.0)


def test_island_load_step_with_rotor_and_voltage_control_settles_where_the_load_balances_the_turbine():
    from simulate.components.electrical.standalone import simulate_unit

    p0, kpf = 0.8, ISLAND.island_frequency_p
    steady = initial_generator_state(GEN, ISLAND, airgap_power_pu=p0, voltage_pu=1.0,
                                     turbine_rated_power_mw=GEN.rated_mva)
    run = simulate_unit(GEN, ISLAND, t_end_s=80.0, dt_s=0.01, steady=steady, inertia_time_s=8.1, excitation=EXC,
                        load_step=(1.0, 1.1))
    # constant mechanical torque p0; the voltage control brings V back to 1, so the electrical torque (air-gap
    # power) is 1.1 p0 (1 + kpf x) and balances p0 at x = -0.1 / (1.1 kpf)
    x_end = (p0 - 1.1 * p0) / (1.1 * p0 * kpf)
    assert run["speed_dev"][-1] == pytest.approx(x_end, rel=1e-3)  # settled: e^-(79 s / 9 s), V within 1e-5
    assert run["terminal_voltage_pu"][-1] == pytest.approx(1.0, abs=1e-5)
    # the swing model with e_g = kpf (on the initial load, not scaled with it) settles at -0.1 / kpf: 10 % apart
    assert x_end == pytest.approx(-0.1 / kpf, rel=0.1 + 1e-9)


def test_compiled_equals_pure_python_with_numba_disabled(tmp_path):
    """``.py_func`` keeps the inner jitted calls compiled; with NUMBA_DISABLE_JIT=1 every function runs as Python."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    script = (
        "import numpy as np, importlib.resources as ir, sys\n"
        "from simulate.components.electrical.generator import load_electrical, initial_generator_state\n"
        "from simulate.components.electrical.standalone import simulate_generator\n"
        "e = load_electrical(ir.files('data_synthetic') / 'generator_table1.toml')\n"
        "st = initial_generator_state(e.generator, e.grid, airgap_power_pu=0.7, voltage_pu=1.0)\n"
        "r = simulate_generator(e.generator, e.grid, t_end_s=1.0, dt_s=0.02, steady=st, excitation=e.excitation,\n"
        "                       load_step=(0.3, 1.1), fault_time_s=0.8, speed_dev=0.001)\n"
        "np.save(sys.argv[1], np.column_stack([r[c] for c in sorted(r.columns)]))\n")
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": str(root) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    for flag, name in (("1", "python.npy"), ("0", "compiled.npy")):
        subprocess.run([sys.executable, "-c", script, str(tmp_path / name)], check=True, cwd=root,
                       env={**env, "NUMBA_DISABLE_JIT": flag})
    # same operations in the same order; LLVM may contract a multiply-add (1 ulp): 1e-12
    np.testing.assert_allclose(np.load(tmp_path / "compiled.npy"), np.load(tmp_path / "python.npy"),
                               rtol=1e-12, atol=1e-12)


def test_a_load_above_the_machines_rated_active_power_is_warned_about():
    """``rated_mva x power_factor`` is the machine's rated active power: the shipped grid plant (250 MVA x 0.9 =
    225 MW, the turbine's rated power) through its load step to 198 MW draws no warning, nor does power factor 0.8
    (200 MW, just above); power factor 0.75 (187.5 MW) does, naming both keys. Only the warnings differ: the run
    itself does not read the power factor."""
    from simulate.components.shaft.generator_shaft import rating_check
    from simulate.config import load_plant
    from simulate.loop.prepare import initial_state, plant_schedules

    plant = load_plant(ir.files("data_synthetic") / "plant_hla339_grid.toml")
    schedules = plant_schedules(plant, initial_state(plant))
    assert rating_check(plant, schedules) == []
    assert rating_check(plant.with_overrides({"generator.power_factor": 0.8}), schedules) == []
    low = plant.with_overrides({"generator.power_factor": 0.75})
    (text,) = rating_check(low, schedules)
    load_mw = float(max(schedules.initial_load, *schedules.load_values)) * plant.turbine.rated_power_mw
    assert 187.5 < load_mw < 200.0  # the largest load lies between the two ratings: the check can go either way
    assert "generator.rated_mva x generator.power_factor = 250 x 0.75 = 187.5 MW" in text
    assert f"{load_mw:.4g} MW" in text
