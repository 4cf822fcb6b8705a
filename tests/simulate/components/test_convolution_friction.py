"""Convolution-based unsteady friction (:mod:`simulate.components.hydraulic.convolution`): the weighting functions'
sums of exponentials against their closed forms, the recursion (U5) against the convolution integrated exactly, the
steady state, and runs: the instantaneous closure of ``test_friction.py`` and the step convergence that Brunone's
explicit form misses."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.special import erf

from hillchart.errors import InputError
from simulate.components.hydraulic import convolution as conv
from simulate.components.hydraulic.friction import steady_reach_loss
from simulate.config import PenstockConfig, PenstockSegment
from simulate.loop.engine import run_simulation
from tests.scripts import load_script
from tests.simulate.components.test_friction import log_decrement, period_peaks, valve_plant


@pytest.mark.parametrize("reynolds", [6630.0, 1e5, 1e7])
@pytest.mark.parametrize("step_tau", [2e-9, 3.6e-6])
def test_vardy_brown_weighting_as_a_sum_of_exponentials(reynolds, step_tau):
    """(U3)-(U4): over tau from one step to 10 / B* (where W has fallen by e^-10) the sum is within 0.5 % of the
    closed form (measured 0.39 % at most, at the long end: the terms below RATE_SPAN_LOW B*; the trapezoid step 1.5
    alone gives 0.2 %). At most 25 terms per history once the terms that forget within a step are one (measured
    15-23)."""
    weights, rates = conv.weighting_terms(reynolds, step_tau)
    b_star = conv.vardy_brown_decay(reynolds)
    tau = np.geomspace(step_tau, 10.0 / b_star, 300)
    approx = np.exp(-np.multiply.outer(tau, rates)) @ weights
    assert np.max(np.abs(approx / conv.weighting(reynolds, tau) - 1.0)) < 5e-3
    assert conv.step_terms(weights, rates, step_tau)[0].size <= 25


def test_a_coarser_rule_fails_the_same_bound(monkeypatch):
    """The failing case of the test above: a trapezoid step of 3 in ln(rate) is 9 % off somewhere."""
    monkeypatch.setattr(conv, "LOG_RATE_STEP", 3.0)
    weights, rates = conv.weighting_terms(1e5, 1e-8)
    tau = np.geomspace(1e-8, 10.0 / conv.vardy_brown_decay(1e5), 300)
    approx = np.exp(-np.multiply.outer(tau, rates)) @ weights
    assert np.max(np.abs(approx / conv.weighting(1e5, tau) - 1.0)) > 0.05


def test_zielke_weighting_as_a_sum_of_exponentials():
    """(U2): 12 terms of the series and its tail as the integral (U4). Against 2000 terms of the series (exact to
    e^-400 for tau >= 1e-5) within 0.5 % (measured 0.17 %, near tau = 1e-3 where the tail's continuum takes over),
    and for tau below 1e-5 within 0.3 % of Zielke's small-tau expansion 0.282095 tau^-1/2 - 1.25 + 1.057855 tau^1/2
    (measured 0.14 %)."""
    weights, rates = conv.weighting_terms(1000.0, 1e-9)
    tau = np.geomspace(1e-5, 1.0, 300)
    approx = np.exp(-np.multiply.outer(tau, rates)) @ weights
    assert np.max(np.abs(approx / conv.weighting(1000.0, tau) - 1.0)) < 5e-3
    small = np.geomspace(1e-9, 1e-5, 50)
    approx = np.exp(-np.multiply.outer(small, rates)) @ weights
    expansion = 0.282095 / np.sqrt(small) - 1.25 + 1.057855 * np.sqrt(small)
    assert np.max(np.abs(approx / expansion - 1.0)) < 3e-3


def test_vardy_brown_decay_by_hand():
    """B* = Re^kappa / 12.86, kappa = log10(15.29 / Re^0.0567): at Re = 1e6 kappa = log10(15.29) - 0.3402."""
    kappa = math.log10(15.29) - 6 * 0.0567
    assert conv.vardy_brown_decay(1e6) == pytest.approx(10 ** (6 * kappa) / 12.86, rel=1e-12)
    with pytest.raises(InputError, match="turbulent flow, Re >= 2000"):
        conv.vardy_brown_decay(1500.0)


@pytest.mark.parametrize("reynolds", [6630.0, 1e7])
@pytest.mark.parametrize("step_tau", [1e-7, 1e-9])
def test_the_recursion_is_the_convolution_of_a_piecewise_linear_velocity(reynolds, step_tau):
    """(U5): with the flow linear over each step, the sum of the terms is the convolution integral, which for (U3)
    is exact in erf: A* sqrt(pi / B*) [erf(sqrt(B* tau_b)) - erf(sqrt(B* tau_a))] per step. A closure-like ramp of
    the flow over half the span (3 / B* or 3000 steps), read at a quarter, half and the whole span: within 0.5 %
    (measured 0.23 % at most). The failing case: the impulse gain m_i exp(-n_i Delta tau / 2) in place of the
    ramp's (the step's change put at its middle) over-weights the terms the step cannot resolve: more than 0.7 %
    off during the ramp (measured 1.1-2.2 %)."""
    b_star = conv.vardy_brown_decay(reynolds)
    steps = int(min(3.0 / (b_star * step_tau), 3000))
    t = np.arange(steps + 1) * step_tau
    change = np.diff(np.where(t < 0.5 * t[-1], 1.0 - t / (0.5 * t[-1]), 0.0))
    weights, rates = conv.weighting_terms(reynolds, step_tau)
    decay, gain = conv.step_terms(weights, rates, step_tau)
    z = rates * step_tau
    y, impulse = np.zeros(decay.size), np.zeros(rates.size)
    a_star = 1.0 / (2.0 * math.sqrt(math.pi))
    for k, dq in enumerate(change):
        y = decay * y + gain * dq  # eq. (U5)
        impulse = np.exp(-z) * impulse + weights * np.exp(-0.5 * z) * dq
        n = k + 1
        if n in (steps // 4, steps // 2, steps):
            tau_a, tau_b = t[n] - t[1:n + 1], t[n] - t[:n]
            exact = float(np.sum(change[:n] / step_tau * a_star * math.sqrt(math.pi / b_star)
                                 * (erf(np.sqrt(b_star * tau_b)) - erf(np.sqrt(b_star * tau_a)))))
            assert y.sum() == pytest.approx(exact, rel=5e-3)
            if n == steps // 4:
                assert abs(impulse.sum() / exact - 1.0) > 7e-3


def test_the_loss_is_the_steady_one_in_steady_flow():
    """(U6) with every term zero: R Q|Q| to the last bit, on both lines of every reach and either flow direction;
    one step of a flow change makes it differ (the failing case)."""
    seg = PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.01)
    pen = PenstockConfig(model="moc", static_head_m=100.0, reaches=4, segments=(seg,), friction_model="convolution")
    from simulate.components.hydraulic.penstock import build_moc_grid

    grid = build_moc_grid(pen, pen.moc_time_step_s)
    compiled = conv.build_convolution_friction(pen, grid, 3.0)
    for q in (3.0, -1.5, 0.0):
        flows = np.full(5, q)
        for reach in range(4):
            for node in (reach, reach + 1):
                assert conv.convolution_reach_loss(compiled.arrays, flows, reach, node) == \
                    steady_reach_loss(grid.friction_s2_m5, flows, reach, node)
    flows = np.full(5, 3.0)
    conv.convolution_advance(compiled.arrays, flows, np.array([3.0, 3.0, 2.9, 3.0, 3.0]))
    assert conv.convolution_reach_loss(compiled.arrays, flows, 1, 2) < steady_reach_loss(grid.friction_s2_m5, flows,
                                                                                          1, 2)
    assert conv.convolution_reach_loss(compiled.arrays, flows, 0, 1) == steady_reach_loss(grid.friction_s2_m5, flows,
                                                                                           0, 1)


def test_a_junction_node_keeps_one_history_per_segment():
    """Two segments of different diameters: the node between them keeps a history for each side (its weights
    differ); a node inside a segment shares one. After a flow change at the junction only, its two sums differ."""
    segs = (PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.01),
            PenstockSegment(length_m=200.0, diameter_m=1.0, wave_speed_m_s=1000.0, darcy_friction=0.01))
    pen = PenstockConfig(model="moc", static_head_m=100.0, reaches=2, segments=segs, friction_model="convolution")
    from simulate.components.hydraulic.penstock import build_moc_grid

    grid = build_moc_grid(pen, pen.moc_time_step_s)
    arrays = conv.build_convolution_friction(pen, grid, 3.0).arrays
    assert grid.reaches_per_segment == (4, 2)
    assert arrays[4].tolist() == [False, True, True, True, False, True, False]
    flows = np.full(7, 3.0)
    changed = flows.copy()
    changed[[2, 4]] = 2.9
    conv.convolution_advance(arrays, flows, changed)
    sums = arrays[6]
    assert sums[0, 2] == sums[1, 2] < 0.0  # inside the first segment: one history
    assert sums[0, 4] < 0.0 and sums[1, 4] < 0.0 and sums[0, 4] != sums[1, 4]  # the junction: two
    # each side is the one its line reads: C+ of reach 4 (foot node 4) and C- of reach 3 (foot node 4)
    assert conv.convolution_reach_loss(arrays, flows, 4, 4) != conv.convolution_reach_loss(arrays, flows, 3, 4)


@pytest.fixture(scope="module")
def closures():
    return {"steady": run_simulation(valve_plant("steady")),
            "convolution": run_simulation(valve_plant("convolution"))}


def test_instantaneous_closure_damps_and_packs_the_line(closures):
    """The reservoir-pipe-valve case of ``test_friction.py`` (Re = 2.5e5) shut at once. Before the closure the run
    is the steady one to the last bit. The first period's peak: 52.01 m against 51.67 m (steady), measured: behind
    the front the flow has decelerated, the convolution turns the wall shear against the old flow and the line packs
    more (Zielke's and Vardy-Brown's models do; Brunone's IAB form cancels its term on an upstream front). The
    logarithmic decrement per period: 0.0352 against 0.0283 (1.24 times), measured. Both figures move by less than
    0.1 % and 0.5 % from 20 to 80 reaches (52.014, 52.027, 52.031 m; 0.03518, 0.03514, 0.03506), so the bounds
    below (0.02 m, 1 %) hold for the model, not the step."""
    before = closures["steady"].time_s < 0.1 - 1e-9
    assert np.array_equal(closures["convolution"].head_m[before], closures["steady"].head_m[before])
    steady, unsteady = period_peaks(closures["steady"]), period_peaks(closures["convolution"])
    assert steady[0] == pytest.approx(51.67, abs=0.01)
    assert unsteady[0] == pytest.approx(52.01, abs=0.02)
    assert log_decrement(unsteady) == pytest.approx(0.0352, rel=0.01)
    assert log_decrement(steady) == pytest.approx(0.0283, rel=0.01)


def test_the_run_reports_the_weighting(closures):
    meta = closures["convolution"].meta
    # Re = 4 Q / (pi D nu) = 2.54e5: turbulent
    assert meta["convolution_weighting"] == "vardy-brown"
    assert meta["convolution_reynolds_min"] == pytest.approx(
        4 * closures["steady"].flow_m3_s[0] / (math.pi * 0.5 * 1e-6), rel=1e-9)
    assert "convolution_terms" not in closures["steady"].meta


@pytest.mark.parametrize("keys,match", [
    (dict(friction_model="steady", convolution_viscosity_m2_s=1.3e-6),
     r"penstock.convolution_viscosity_m2_s is a key of penstock.friction_model = 'convolution'; with friction_model "
     r"= 'steady' it would be ignored"),
    (dict(friction_model="brunone", convolution_viscosity_m2_s=1.3e-6), r"with friction_model = 'brunone'"),
    (dict(friction_model="convolution", convolution_viscosity_m2_s=1.0), r"penstock.convolution_viscosity_m2_s "
                                                                          r"must be in \[1e-07, 0.0001\], got 1.0"),
    (dict(friction_model="convolution", brunone_k3=0.01), r"penstock.brunone_k3 is a key of"),
])
def test_the_models_key_is_refused_elsewhere(keys, match):
    seg = PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.01)
    with pytest.raises(InputError, match=match):
        PenstockConfig(**{"model": "moc", "static_head_m": 100.0, "reaches": 4, "segments": (seg,), **keys})
    PenstockConfig(model="moc", static_head_m=100.0, reaches=4, segments=(seg,), friction_model="convolution",
                   convolution_viscosity_m2_s=1.3e-6)


BULB = Path(__file__).resolve().parents[3] / "data_synthetic" / "plant_bulb.toml"


@pytest.mark.parametrize("keys,match", [
    ({"draft_tube.brunone_k3": 0.01},
     r"draft_tube.brunone_k3 is a key of draft_tube.friction_model = 'brunone'; with friction_model = 'convolution' "
     r"it "
     r"would be ignored"),
    ({"draft_tube.friction_model": "brunone", "draft_tube.brunone_k3": 0.01,
      "draft_tube.brunone_viscosity_m2_s": 1.3e-6},
     r"draft_tube.brunone_viscosity_m2_s = 1.3e-06 would be ignored: draft_tube.brunone_k3 = 0.01 is given"),
    ({"draft_tube.friction_model": "brunone", "draft_tube.model": "rigid"},
     r"draft_tube.friction_model = 'brunone' is read only by draft_tube.model = moc; with model = 'rigid'"),
    ({"draft_tube.friction_model": "darcy"}, r"draft_tube.friction_model must be one of steady, brunone, convolution"),
])
def test_the_draft_tubes_friction_keys_are_checked_under_its_own_name(keys, match):
    from simulate.config import load_plant

    with pytest.raises(InputError, match=match):
        load_plant(BULB, keys)


def test_the_draft_tube_runs_the_friction_model_it_is_given():
    """The shipped bulb plant's MOC draft tube (30 m, 5.5 m) with each friction model, the penstock's loss held
    quasi-steady so that the draft tube's alone moves the figures: before the event (1 s) the
    convolution's run is the steady one's within 1e-8 m (measured 1.6e-9 m, bounded, not growing: the plant's own
    initial state is not stationary to the last bit, and Brunone's term, or the convolution in the penstock, moves it
    as much); afterwards its smallest outlet pressure head is 8.2281 m against 8.2324 m
    (steady) and 8.2260 m (Brunone), measured: the model is bound into the draft tube's lines, not only the
    penstock's. Halving the step (4 -> 8 penstock reaches) moves it by -0.043 % with either model."""
    from simulate.config import load_plant

    runs = {(f, n): run_simulation(load_plant(BULB, {"draft_tube.friction_model": f, "penstock.reaches": n,
                                                     "penstock.friction_model": "steady"}))
            for f in ("steady", "convolution") for n in (4, 8)}
    steady, conv = runs["steady", 4], runs["convolution", 4]
    before = steady.time_s < 1.0 - 1e-9
    assert np.max(np.abs(conv.head_m[before] - steady.head_m[before])) < 1e-8
    low = {k: r.summary()["min_outlet_pressure_head_m"] for k, r in runs.items()}
    assert low["steady", 4] == pytest.approx(8.2324, abs=2e-4)
    assert low["convolution", 4] == pytest.approx(8.2281, abs=2e-4)
    assert conv.meta["draft_tube_friction_model"] == "convolution"
    for f in ("steady", "convolution"):
        assert abs(low[f, 8] / low[f, 4] - 1.0) < 1e-3


def test_the_exact_laminar_mode_follows_the_stokes_layer():
    """Eqs. (L1)-(L3) of ``benchmarks/bench_laminar_decay.py``, checked apart from any run: at high frequency the
    wall shear lives in a Stokes layer and the fundamental decays at sigma = sqrt(nu omega_0 / 2) / R (0.4431 1/s
    here); the next term of the expansion is of relative order 1 / (R sqrt(omega / nu)) = 0.016, so the exact mode is
    within 2 % of it (measured 0.4482, +1.2 %). A mode whose steady part is removed, (L2), decays slower by about the
    quasi-steady 16 nu / D^2 = 0.04 1/s (measured 0.4088), and without viscosity the mode is the frictionless
    i pi a / (2 L) less the Stokes layer's shift."""
    bench = load_script("bench_laminar_decay")
    omega0 = math.pi * bench.WAVE_SPEED_M_S / (2 * bench.LENGTH_M)
    radius = bench.DIAMETER_M / 2
    s = bench.fundamental()
    assert -s.real == pytest.approx(math.sqrt(bench.VISCOSITY_M2_S * omega0 / 2) / radius, rel=0.02)
    without = bench.fundamental(steady=False)
    assert s.real - without.real == pytest.approx(-16 * bench.VISCOSITY_M2_S / bench.DIAMETER_M ** 2, rel=0.05)
    # a thin Stokes layer (nu = 1e-14): the next term vanishes, the asymptote holds to 0.1 %, the mode is frictionless
    thin = bench.fundamental(viscosity_m2_s=1e-14)
    assert -thin.real == pytest.approx(math.sqrt(1e-14 * omega0 / 2) / radius, rel=1e-3)
    assert thin.imag == pytest.approx(omega0, rel=1e-5)


def test_laminar_ringing_decays_as_the_exact_theory():
    """The classical damping case (``benchmarks/bench_laminar_decay.py``): a valve shut in 2 ms at the end of a
    laminar pipe (Re = 1000). The convolution with Zielke's weighting and no steady loss against the exact mode
    (L2): the decay rate within 0.5 % of the exact 0.4088 1/s at dt = 0.5 ms (measured +0.16 %; +0.69 % at 1 ms,
    -0.06 % at 0.25 ms: it converges as the step shrinks) and the frequency within 0.01 % (measured 0.000 %).
    Deterministic runs: the tolerances are the model's, not the CPU's (whose spread is below 1e-9 here). The failing
    case: the quasi-steady loss alone decays at 0.04 1/s against the exact 0.448 of (L1), 91 % short."""
    bench = load_script("bench_laminar_decay")
    exact = bench.fundamental(steady=False)
    sigma, omega = bench.measure("convolution", 80, exact.imag, steady_loss=False)
    assert sigma == pytest.approx(-exact.real, rel=0.005)
    assert omega == pytest.approx(exact.imag, rel=1e-4)
    coarse, _ = bench.measure("convolution", 40, exact.imag, steady_loss=False)
    assert coarse == pytest.approx(sigma, rel=0.01)  # dt and dt / 2 within 1 % (measured 0.5 %)
    full = bench.fundamental()
    quasi, _ = bench.measure("steady", 80, full.imag)
    assert quasi < 0.1 * -full.real
