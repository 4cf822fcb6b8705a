"""Validation of the transient simulator: analytic truth and cross-checks."""

from dataclasses import replace
from importlib import resources

import numpy as np
import pytest
from scipy.linalg import expm

from hillchart.characteristics import IdealTurbine, scalar_kernel
from hillchart.constants import G_M_S2
from hillchart.synthetic.francis import SyntheticFrancis
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                             ScenarioConfig, SolverConfig, TurbineConfig, load_characteristics, load_plant)
from simulate.loop.engine import initial_state, run_simulation

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"
#: Opening step of the linearization check (stroke fraction; 0.16 mm of 32 mm on the synthetic turbine).
STEP = 0.005


def example(**overrides):
    """The shipped plant with the ideal turbine (the nets file ships separately) and extra overrides."""
    return load_plant(PLANT_FILE, {"turbine.characteristics": "ideal", **overrides})


def valve_plant(segments, reaches=10, closing_time_s=0.0, t_end_s=7.0):
    """A valve (ideal turbine) at the end of a frictionless pipe, programmatic construction."""
    turbine = TurbineConfig(rated_head_m=100.0, rated_flow_m3_s=10.0, rated_speed_rpm=300.0, rated_power_mw=9.0,
                            runner_diameter_m=2.0, opening_max=1.0, characteristics="ideal")
    # the analytic references have the steady loss and no free gas (the DVCM: no cavity forms, the plain MOC)
    penstock = PenstockConfig(model="moc", static_head_m=100.0, reaches=reaches, segments=tuple(segments),
                              friction_model="steady", column_separation="dvcm")
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
                              servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    scenario = ScenarioConfig(kind="closure-law", t_end_s=t_end_s, initial_opening=0.25, event_time_s=0.1,
                              closing_time_s=closing_time_s)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=GeneratorConfig(inertia_time_s=8.0),
                       governor=governor, scenario=scenario, solver=SolverConfig())


@pytest.mark.parametrize("split", [False, True])
def test_joukowsky_head_rise_and_period(split):
    # One 400 m pipe, or the same pipe as two segments joined at a junction: instantaneous closure of a valve
    # gives the Joukowsky rise a V0 / g, and the head at the valve is a square wave of period 4 L / a.
    length, diameter, a = 400.0, 2.0, 1000.0
    if split:
        segs = [PenstockSegment(length_m=150.0, diameter_m=diameter, wave_speed_m_s=a, darcy_friction=0.0),
                PenstockSegment(length_m=250.0, diameter_m=diameter, wave_speed_m_s=a, darcy_friction=0.0)]
    else:
        segs = [PenstockSegment(length_m=length, diameter_m=diameter, wave_speed_m_s=a, darcy_friction=0.0)]
    plant = valve_plant(segs, reaches=3 if split else 8)
    result = run_simulation(plant)
    h0, q0 = result.head_m[0], result.flow_m3_s[0]
    v0 = q0 / (np.pi * diameter ** 2 / 4)
    rise = result.head_m.max() - h0
    # 0.5 % is the promised accuracy; frictionless MOC at Courant 1 is exact up to rounding
    assert rise == pytest.approx(a * v0 / G_M_S2, rel=5e-3)
    assert rise == pytest.approx(a * v0 / G_M_S2, rel=1e-9)
    # period from the upward crossings of H0 (square wave): 4 L / a within one time step
    dev = result.head_m - h0
    ups = result.time_s[1:][(dev[:-1] <= 1e-6 * h0) & (dev[1:] > 1e-6 * h0)]
    assert len(ups) >= 4
    period = np.diff(ups).mean()
    dt = result.meta["dt_s"]
    assert abs(period - 4 * length / a) <= dt + 1e-12
    # the flow at the valve is exactly zero after closure (guarded boundary at a = 0, no NaN)
    closed = result.opening == 0.0
    assert closed.sum() > 10 and np.all(result.flow_m3_s[closed] == 0.0)
    assert np.all(np.isfinite(result.head_m))


@pytest.mark.parametrize("turbine", ["ideal", "synthetic", "nets"])
def test_three_pressure_loops_give_the_same_trajectory(turbine):
    # The example load rejection (MOC): all three loops converge to 1e-10 of the rated head each step, so the
    # trajectories agree far inside the promised 1e-6 relative. The traditional loop needs relaxation 0.5 here
    # (|k dQ/dH| ~ 1.9 with alpha = 1 diverges, see benchmarks/bench_pressure_loop.py).
    chars = SyntheticFrancis() if turbine == "synthetic" else None
    runs = {}
    for loop in ("improved", "newton", "traditional"):
        plant = example(**{"turbine.characteristics": "ideal" if turbine != "nets" else "francis/nets.json",
                           "solver.pressure_loop": loop, "solver.relaxation": 0.5 if loop == "traditional" else 1.0,
                           "scenario.t_end_s": 30.0 if turbine == "ideal" else 15.0})
        runs[loop] = run_simulation(plant, chars)
    ref = runs["improved"]
    for loop in ("newton", "traditional"):
        for name in ("speed_rpm", "head_m", "flow_m3_s", "opening"):
            a, b = getattr(runs[loop], name), getattr(ref, name)
            scale = np.abs(b).max()
            assert np.max(np.abs(a - b)) / scale < 1e-6, (loop, name)
    if turbine == "ideal":
        # the improved loop needs at most 2 evaluations per step with the ideal turbine (Q11 independent of N11)
        assert ref.iterations[1:].max() == 2
    # relaxed traditional loop: measured 23 (ideal) and 11.0 (synthetic) mean iterations vs 2.0 and 4.5 improved
    assert runs["traditional"].iterations[1:].mean() > 2 * ref.iterations[1:].mean()


@pytest.mark.parametrize("model", ["moc", "zdomain", "lumped", "rigid"])
@pytest.mark.parametrize("loop", ["improved", "newton"])
def test_undisturbed_steady_state_holds_for_100_s(model, loop):
    # No event inside the 100 s: the verified initial state must not drift (|dn/n| < 1e-9)
    plant = example(**{"penstock.model": model, "solver.pressure_loop": loop, "scenario.t_end_s": 100.0,
                       "scenario.event_time_s": 99.99})
    result = run_simulation(plant)
    before = result.time_s < 99.99
    assert np.max(np.abs(result.speed_rpm[before] / result.speed_rpm[0] - 1.0)) < 1e-9
    # head: within the loop tolerance (1e-10 of rated head) of its start
    assert np.max(np.abs(result.head_m[before] / result.head_m[0] - 1.0)) < 1e-9
    assert result.meta["steady_state_max_residual"] < 1e-9


def test_penstock_models_agree_on_a_slow_closure():
    # Closure over ~20 s (Tw = 1.48 s, 2L/a = 0.88 s). During the closure all four models carry the same
    # water-inertia pressure rise; they differ by the elastic front at the start of the closure (MOC: a wave;
    # zdomain/lumped: a second-order resonance; rigid: none) and after full closure (each rings at its own frequency:
    # MOC 4L/a, lumped its first mode, zdomain the Tustin resonance 2/T_so; rigid not at all).
    # Measured: head differences to MOC during closure 0.34 % (zdomain, lumped), 0.50 % (rigid) of H0;
    # maximum head rise within 3e-5 of H0; speed within 0.04 % of rated over the whole run.
    plant = example(**{"scenario.kind": "closure-law", "scenario.closing_time_s": 20.0, "scenario.t_end_s": 25.0})
    ref = run_simulation(plant)
    runs = {m: run_simulation(plant.with_overrides({"penstock.model": m, "solver.dt_s": ref.meta["dt_s"]}))
            for m in ("zdomain", "lumped", "rigid")}  # on the MOC grid's step, to compare sample by sample
    h0 = ref.head_m[0]
    closing_end = 2.0 + ref.opening[0] * 20.0
    during = ref.time_s <= closing_end
    for model, bound in (("zdomain", 0.006), ("lumped", 0.006), ("rigid", 0.01)):
        run = runs[model]
        assert np.max(np.abs(run.head_m - ref.head_m)[during]) / h0 < bound, model  # few-tenths %, see above
        assert abs(run.summary()["max_head_rise"] - ref.summary()["max_head_rise"]) < 1e-3, model
        assert np.max(np.abs(run.speed_rpm - ref.speed_rpm)) / ref.speed_rpm[0] < 1e-3, model
    # and the elastic models do differ from the rigid one (the test could fail): MOC oscillates below H0
    assert ref.summary()["min_head_drop"] > 0.03 and runs["rigid"].summary()["min_head_drop"] < 1e-9


def _plant_partials(kernel, params, turbine, speed, opening, head):
    """Q(n, a, H) and M(n, a, H) partials by central finite differences (relative step 1e-6)."""
    d1 = turbine.runner_diameter_m

    def qm(n, a, h):
        out = kernel(params, n * d1 / np.sqrt(h), a)
        return np.array([out[0] * d1 ** 2 * np.sqrt(h), out[3] * d1 ** 3 * h])

    grads = []
    for i, x in enumerate((speed, opening, head)):
        step = 1e-6 * x
        plus, minus = [speed, opening, head], [speed, opening, head]
        plus[i] += step
        minus[i] -= step
        grads.append((qm(*plus) - qm(*minus)) / (2 * step))
    return np.array(grads).T  # rows Q, M; columns d/dn, d/da, d/dH


@pytest.mark.slow
@pytest.mark.parametrize("characteristics", ["ideal", "synthetic"])
def test_small_opening_step_matches_linearized_response(characteristics):
    # Open-loop +0.005 stroke step at 1 s, rigid penstock with friction, constant load with self-regulation.
    # Linear model in deviations: I dQ/dt = -dH - 2 K Q0 dQ; Ta dx/dt = dM/M_r - e_g x; dQ = Qn dn + Qa da + QH dH,
    # with the six plant partials by finite differences. Bound: 2 % of the peak speed deviation. Measured
    # error/peak: ideal 0.20 %; synthetic Francis 0.93 %, growing in proportion to the step (0.47 %, 0.93 %, 1.85 %
    # for 0.0025, 0.005, 0.01), i.e. the characteristics' curvature, not the integration (Euler ~dt/Ta = 0.2 %).
    plant = example(**{"scenario.kind": "opening-steps", "scenario.opening_steps": [STEP],
                       "scenario.step_times_s": [1.0], "scenario.t_end_s": 40.0, "scenario.initial_power_mw": 180.0,
                       "penstock.model": "rigid"})
    chars = SyntheticFrancis() if characteristics == "synthetic" else load_characteristics(plant.turbine)
    result = run_simulation(plant, chars)
    kernel, params, _ = scalar_kernel(chars)
    s0 = initial_state(plant, chars)
    t = plant.turbine
    (qn, qa, qh), (mn, ma, mh) = _plant_partials(kernel, params, t, s0.speed_rpm, s0.opening_chart, s0.head_m)
    inertance = plant.penstock.inertance_s2_m2
    k2 = 2 * plant.penstock.friction_coefficient_s2_m5 * s0.flow_m3_s
    n_r, m_r, ta, e_g = t.rated_speed_rpm, t.rated_torque_nm, plant.generator.inertia_time_s, \
        plant.generator.self_regulation
    da = STEP * t.opening_max
    # states z = [dQ, x]; dH = (dQ - qn n_r x - qa da) / qh
    a_mat = np.array([[(-1 / qh - k2) / inertance, qn * n_r / qh / inertance],
                      [mh / qh / m_r / ta, (mn * n_r - mh * qn * n_r / qh) / m_r / ta - e_g / ta]])
    b_vec = np.array([qa / qh / inertance, (ma - mh * qa / qh) / m_r / ta]) * da
    after = result.time_s >= 1.0 - 1e-9
    tau = result.time_s[after] - result.time_s[after][0]
    # exact step response z(t) = A^-1 (expm(A t) - I) b
    lin_x = np.array([np.linalg.solve(a_mat, (expm(a_mat * s) - np.eye(2)) @ b_vec)[1] for s in tau])
    sim_x = result.speed_rpm[after] / n_r - 1.0
    peak = np.abs(lin_x).max()
    assert peak > 1e-3  # the step does move the unit
    assert np.max(np.abs(sim_x - lin_x)) < 0.02 * peak


@pytest.mark.parametrize("kind,turbine", [("load-rejection", "ideal"), ("closure-law", "ideal"),
                                          ("frequency-steps", "ideal"), ("load-step", "ideal"),
                                          ("opening-steps", "ideal"), ("load-rejection", "francis/nets.json")])
def test_compiled_and_python_loops_are_the_same_source(kind, turbine):
    # jit=False runs _time_loop.py_func with the Python kernel: results equal the compiled run to rounding
    extra = {"scenario.closing_time_s": 10.0} if kind == "closure-law" else {}
    plant = example(**{"scenario.kind": kind, "scenario.t_end_s": 4.0, **extra, "turbine.characteristics": turbine,
                       **({} if kind == "frequency-steps" else {"scenario.initial_power_mw": 200.0}),
                       **({"scenario.event_time_s": 1.0} if kind in ("load-rejection", "closure-law",
                                                                       "load-step") else {}),
                       **({"scenario.step_times_s": [1.0], "scenario.speed_steps": [0.04]}
                          if kind == "frequency-steps" else {})})
    fast = run_simulation(plant)
    slow = run_simulation(plant, jit=False)
    assert fast.meta["compiled"] and not slow.meta["compiled"]
    for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * np.abs(b).max(), name  # fused multiply-add may differ in ulps
    assert np.array_equal(fast.iterations, slow.iterations)


def test_python_only_characteristics_run_through_the_same_loop():
    # An object without numba_kernel (only the four protocol methods) drives the Python loop.
    class Wrapped:
        def __init__(self, inner):
            self.inner = inner

        def q11(self, n11, a):
            return self.inner.q11(n11, a)

        def m11(self, n11, a):
            return self.inner.m11(n11, a)

        def q11_grad(self, n11, a):
            return self.inner.q11_grad(n11, a)

        def m11_grad(self, n11, a):
            return self.inner.m11_grad(n11, a)

    plant = example(**{"scenario.t_end_s": 3.0, "scenario.event_time_s": 1.0})
    ideal = load_characteristics(plant.turbine)
    ref = run_simulation(plant, ideal)
    wrapped = run_simulation(plant, Wrapped(ideal))
    assert not wrapped.meta["compiled"]
    assert np.max(np.abs(wrapped.speed_rpm - ref.speed_rpm)) < 1e-9 * ref.speed_rpm[0]
    assert np.max(np.abs(wrapped.head_m - ref.head_m)) < 1e-9 * ref.head_m[0]


def test_programmatic_plant_with_any_characteristics():
    # A user-built IdealTurbine with lower efficiency passed directly: the initial opening for the same power rises
    # by the efficiency ratio (power proportional to eta * stroke at fixed head and flow law).
    plant = example(**{"scenario.t_end_s": 3.0})
    base = load_characteristics(plant.turbine)
    weaker = IdealTurbine(q11_max_m3_s=base.q11_max_m3_s, opening_max=base.opening_max,
                          efficiency=0.9 * base.efficiency)
    plant = replace(plant, scenario=replace(plant.scenario, initial_power_mw=150.0))
    s_base, s_weak = initial_state(plant, base), initial_state(plant, weaker)
    assert s_weak.power_mw == pytest.approx(150.0, rel=1e-9)
    assert s_weak.stroke > s_base.stroke * 1.05  # needs more flow: more friction, so a bit more than 1/0.9
    assert run_simulation(plant, weaker).success
