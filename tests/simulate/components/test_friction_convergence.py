"""Unsteady friction on the shipped plants (``benchmarks/bench_friction_decay.py``): halving the step moves the demo
rejection's extreme heads by less than 0.1 % with Brunone's friction on, as with the steady loss; the surge-tank
plant's 100 s of ringing shows the first-order time error of the Brunone form (the failing case); the ringing after
the demo's closure decays with Brunone and hardly with the steady loss. The convolution model converges on every
shipped plant, the surge-tank plant included."""

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def bench():
    return load_script("bench_friction_decay")


def test_halving_the_step_moves_the_demo_rejection_by_less_than_0_1_percent(bench):
    """The demo plant (8 reaches, dt = 0.0191 s) against 16 reaches: the largest head moves +0.0022 % with Brunone
    (+0.0022 % steady), the smallest -0.0045 % (-0.0025 % steady), measured; the acceptance is 0.1 %, and each
    change is pinned to 0.002 percentage points (a change of the discretisation that doubled the error fails; that
    Brunone's term acts here is the decay test's below)."""
    brunone = bench.step_convergence("plant_hla339.toml", "brunone")
    steady = bench.step_convergence("plant_hla339.toml", "steady")
    assert brunone.converged and steady.converged
    assert brunone.max_change_pct == pytest.approx(0.0022, abs=0.002)
    assert brunone.min_change_pct == pytest.approx(-0.0045, abs=0.002)
    assert steady.min_change_pct == pytest.approx(-0.0025, abs=0.002)


def test_the_surge_tank_plants_long_ringing_is_the_failing_case(bench):
    """The surge-tank plant's smallest head comes 94 s after the rejection, after 94 s of ringing that Brunone's
    friction damps; the explicit form's damping rate carries an error of the order of omega dt (the local
    acceleration Q^n - Q^(n-1) lags the step it acts on by half a step), so halving the step moves that head by
    -0.14 % (measured -0.1370 %), more than 0.1 %; the steady loss, which hardly damps the ringing, moves it by
    +0.029 %."""
    brunone = bench.step_convergence("plant_hla339_surge_tank.toml", "brunone")
    steady = bench.step_convergence("plant_hla339_surge_tank.toml", "steady")
    assert not brunone.converged and steady.converged
    assert brunone.min_change_pct == pytest.approx(-0.137, abs=0.01)
    assert abs(brunone.max_change_pct) < bench.CONVERGED_PCT  # the first peak, before the ringing, converges


def test_the_surge_tank_plants_error_is_first_order(bench):
    """Halving the step again (16 -> 32 reaches) halves the change of the smallest head: -0.0727 % against -0.1370 %
    (ratio 1.88 measured; a first-order error gives 2, a second-order one 4: [1.7, 2.4] tells them apart)."""
    fine = bench.step_convergence("plant_hla339_surge_tank.toml", "brunone", reaches=16)
    assert fine.min_change_pct == pytest.approx(-0.0727, abs=0.01)
    assert 1.7 < -0.1370 / fine.min_change_pct < 2.4


def test_the_demo_ringing_decays_with_brunone(bench):
    """After the demo's closure (flow below 1e-3 Q0 at 10.64 s) the ringing amplitude over the last of four 10 s
    windows is 0.958 of the first's with Brunone (rate 0.00143 1/s), 0.991 with the steady loss (0.00029 1/s):
    4.9 times the rate, asserted above 4.5 (5.2 with earlier shipped nets: the steady loss's rate is a few 1e-4 1/s,
    and its share moves the ratio by tenths). At 16 reaches the rate is 0.00136 1/s: within 8 % (the first-order
    error of the explicit form's damping, as in the surge-tank test above: 5.1 % measured with the shipped nets,
    3.2 %, 5.2 % and 3.7 % with earlier ones)."""
    brunone, _ = bench.demo_decay("brunone")
    steady, result = bench.demo_decay("steady")
    assert bench.closure_end_s(result) == pytest.approx(10.64, abs=0.02)
    assert brunone.amplitudes_m.size == steady.amplitudes_m.size == 4
    assert brunone.ratio == pytest.approx(0.9580, abs=0.002)
    assert steady.ratio == pytest.approx(0.9912, abs=0.002)
    assert brunone.rate_per_s > 4.5 * steady.rate_per_s
    halved, _ = bench.demo_decay("brunone", reaches=16)
    assert halved.rate_per_s == pytest.approx(brunone.rate_per_s, rel=0.08)


def _ringing(rate_per_s: float, t_end_s: float = 46.0):
    """A closure at 5 s, then a head ringing at the demo's period 1.7 s whose amplitude falls as exp(-rate t)."""
    t = np.arange(0.0, t_end_s, 0.005)
    flow = np.where(t < 5.0, 100.0 * (1.0 - t / 5.0), 0.0)
    head = 180.0 + np.where(t < 5.0, 0.0, 30.0 * np.exp(-rate_per_s * (t - 5.0)) * np.sin(2 * math.pi * t / 1.7))
    return SimpleNamespace(time_s=t, head_m=head, flow_m3_s=flow)


def test_the_decay_measure_recovers_a_known_rate(bench):
    """An exponentially decaying sinusoid: the windows' standard deviation falls by exp(-rate * 10 s) per window,
    up to the part-period at each window's end (10 s is 5.9 periods): the rate within 3 %; no decay reads as
    (nearly) none, and a run without a closure or too short after it is refused."""
    centres, amplitudes = bench.window_amplitudes(_ringing(0.02))
    assert centres[0] == pytest.approx(10.0, abs=0.01) and amplitudes.size == 4
    decay = bench.Decay("synthetic", 0, centres, amplitudes)
    assert decay.rate_per_s == pytest.approx(0.02, rel=0.03)
    flat = bench.Decay("synthetic", 0, *bench.window_amplitudes(_ringing(0.0)))
    assert abs(flat.rate_per_s) < 1e-3
    open_valve = _ringing(0.0)
    open_valve.flow_m3_s = np.full_like(open_valve.time_s, 50.0)
    with pytest.raises(ValueError, match="never falls below"):
        bench.window_amplitudes(open_valve)
    with pytest.raises(ValueError, match="at least 2"):
        bench.window_amplitudes(_ringing(0.02, t_end_s=20.0))


def test_the_surge_tank_plant_converges_with_the_convolution(bench):
    """The failing case of Brunone's explicit form above passes with the convolution (its damping set by the
    weighting function integrated exactly over each step, not by a lagged difference): halving the step moves the
    surge-tank plant's smallest head by +0.004 % and its largest by +0.004 % (measured), inside 0.1 %; pinned to
    0.01 percentage points (Brunone's -0.14 % would fail)."""
    conv = bench.step_convergence("plant_hla339_surge_tank.toml", "convolution")
    assert conv.converged
    assert conv.min_change_pct == pytest.approx(0.0038, abs=0.01)
    assert conv.max_change_pct == pytest.approx(0.0039, abs=0.01)


@pytest.mark.parametrize("plant", ["plant_hla339.toml", "plant_bulb.toml", "plant_pump_turbine.toml"])
def test_the_shipped_plants_converge_with_the_convolution(bench, plant):
    """Halving the step moves each shipped plant's extreme heads by less than 0.1 % with the convolution (measured:
    demo +0.0024 / -0.0028 %, bulb -0.0090 / +0.0348 %, pump-turbine -0.0164 / +0.0158 %)."""
    assert bench.step_convergence(plant, "convolution").converged


def test_the_demo_ringing_decays_with_the_convolution(bench):
    """The demo's ringing with the convolution: last window 0.979 of the first (rate 0.00071 1/s, 2.6 times the
    steady loss's 0.00027; Brunone's 0.00140), and the same rate within 3 % at 16 reaches (measured 0.00070: the
    damping is the model's, not the step's). Vardy and Brown's weighting at the steady Reynolds number (2.8e7 in
    the upper pipe) forgets within a few hundredths of a second, so it damps less than Brunone's k3 at that Re."""
    conv, _ = bench.demo_decay("convolution")
    steady, _ = bench.demo_decay("steady")
    assert conv.ratio == pytest.approx(0.9789, abs=0.002)
    assert conv.rate_per_s > 2.5 * steady.rate_per_s
    halved, _ = bench.demo_decay("convolution", reaches=16)
    assert halved.rate_per_s == pytest.approx(conv.rate_per_s, rel=0.03)
