"""The synthetic Francis turbine: physics sanity against HLA339-like targets, exact derivatives, and the
shipped chart regenerating (to a tolerance across CPUs, bit for bit on one machine)."""

import filecmp

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.characteristics import Characteristics
from hillchart.errors import InputError
from hillchart.synthetic.francis import FrancisParameters, SyntheticFrancis, write_synthetic_chart
from tests.chart_files import CHART_FILES, assert_chart_matches, assert_csv_matches

TURBINE = SyntheticFrancis()
# HLA339-LJ-450: 200 r/min, D1 = 4.5 m, 176 m, 142.5 m^3/s
RATED_N11 = 200 * 4.5 / np.sqrt(176.0)
RATED_Q11 = 142.5 / (4.5**2 * np.sqrt(176.0))


def _best_efficiency_point():
    n, a = np.meshgrid(np.linspace(40, 100, 241), np.linspace(2, 32, 121))
    eta = TURBINE.efficiency(n, a)
    i = np.unravel_index(np.argmax(eta), eta.shape)
    return eta[i], n[i], a[i]


def test_is_a_characteristics_object():
    assert isinstance(TURBINE, Characteristics)


def test_best_efficiency_in_the_issue_window():
    eta, n11, _ = _best_efficiency_point()
    assert 0.92 <= eta <= 0.94  # the HLA339-like target: best efficiency 0.92-0.94 ...
    assert 60 <= n11 <= 70  # ... at N11 60-70


@pytest.mark.parametrize("opening", [8.0, 16.0, 24.0, 32.0])
def test_runaway_ratio(opening):
    _, n11_best, _ = _best_efficiency_point()
    ratio = TURBINE.runaway_n11(opening) / n11_best
    assert 1.6 <= ratio <= 2.2  # the HLA339-like target: runaway N11 1.6-2.2 times the best-efficiency N11
    assert abs(float(TURBINE.m11(TURBINE.runaway_n11(opening), opening))) < 1e-9


def test_zero_opening_is_closed_and_brakes():
    n11 = np.linspace(0, 140, 15)
    assert np.all(TURBINE.q11(n11, 0.0) == 0.0)  # exact: sin(alpha1) = 0
    np.testing.assert_allclose(TURBINE.m11(n11, 0.0), -TURBINE.params.k_disc_friction * n11**2, rtol=1e-12, atol=1e-12)


def test_rated_point_inside_chart():
    from hillchart.io.samples import load_chart

    chart = load_chart(FRANCIS_DIR)
    assert chart.flow_n11.min() < RATED_N11 < chart.flow_n11.max()
    assert chart.flow_q11.min() < RATED_Q11 < chart.flow_q11.max()
    # an opening in the chart gives the rated flow at the rated speed
    q_low, q_high = TURBINE.q11(RATED_N11, chart.openings[0]), TURBINE.q11(RATED_N11, chart.openings[-1])
    assert q_low < RATED_Q11 < q_high


def test_small_openings_lose_flow_with_speed():
    # centrifugal effect of a medium-head Francis: Q11 falls with N11 at small openings
    assert TURBINE.q11(100.0, 8.0) < TURBINE.q11(60.0, 8.0) < TURBINE.q11(20.0, 8.0)


def test_complex_step_derivatives_match_central_differences():
    rng = np.random.default_rng(1)
    n11, a = rng.uniform(5, 130, 50), rng.uniform(1, 31, 50)
    h = 1e-4
    for f, grad in ((TURBINE.q11, TURBINE.q11_grad), (TURBINE.m11, TURBINE.m11_grad)):
        d_n, d_a = grad(n11, a)
        fd_n = (f(n11 + h, a) - f(n11 - h, a)) / (2 * h)
        fd_a = (f(n11, a + h) - f(n11, a - h)) / (2 * h)
        scale_n = np.abs(fd_n).max()
        scale_a = np.abs(fd_a).max()
        # central differences with h = 1e-4 carry O(h^2) ~ 1e-8 relative truncation plus rounding
        np.testing.assert_allclose(d_n, fd_n, rtol=1e-6, atol=1e-7 * scale_n)
        np.testing.assert_allclose(d_a, fd_a, rtol=1e-6, atol=1e-7 * scale_a)


def test_truth_csv_tabulates_the_model():
    truth = np.loadtxt(FRANCIS_DIR / "truth.csv", delimiter=",", skiprows=1)
    n11, a, q11, m11, eta = truth.T
    assert n11.min() == 0 and a.min() == 0 and a.max() == TURBINE.opening_max
    assert n11.max() > 1.1 * TURBINE.runaway_n11(TURBINE.opening_max)  # beyond runaway speed
    # written with 10 significant digits
    np.testing.assert_allclose(q11, TURBINE.q11(n11, a), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(m11, TURBINE.m11(n11, a), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(eta, TURBINE.efficiency(n11, a), rtol=1e-9, atol=1e-12)


def test_shipped_chart_regenerates_on_any_cpu(tmp_path):
    """The shipped chart files come back from ``write_synthetic_chart(seed=0)``, to the last written digit
    (:mod:`tests.chart_files` says why not bit for bit across CPUs); another seed fails that by far."""
    write_synthetic_chart(tmp_path, seed=0)
    assert_chart_matches(tmp_path, FRANCIS_DIR)
    # the failing case: the noise of another seed moves the digitized points by far more than the tolerance
    other = tmp_path / "other"
    write_synthetic_chart(other, seed=7)
    flow_other = np.loadtxt(other / "flow.csv", delimiter=",", skiprows=1)
    flow_shipped = np.loadtxt(FRANCIS_DIR / "flow.csv", delimiter=",", skiprows=1)
    assert np.max(np.abs(flow_other - flow_shipped)[:, 2]) > 10 * 1e-4  # Q11 written to 1e-4


def test_chart_is_bit_identical_on_one_machine(tmp_path):
    """On one machine, the same seed writes the same bytes (what makes the shipped files auditable)."""
    write_synthetic_chart(tmp_path / "a", seed=0)
    write_synthetic_chart(tmp_path / "b", seed=0)
    for name in CHART_FILES:
        assert filecmp.cmp(tmp_path / "a" / name, tmp_path / "b" / name, shallow=False), name


def test_other_seed_changes_only_the_noise(tmp_path):
    write_synthetic_chart(tmp_path, seed=7)
    assert (tmp_path / "flow.csv").read_text() != (FRANCIS_DIR / "flow.csv").read_text()
    assert_csv_matches(tmp_path / "truth.csv", FRANCIS_DIR / "truth.csv")


def test_chart_sizes_meet_the_issue():
    from hillchart.io.samples import load_chart

    chart = load_chart(FRANCIS_DIR)
    assert chart.openings.size >= 8
    assert np.unique(chart.eff_efficiency).size >= 8 and chart.eff_efficiency.min() <= 0.80 + 1e-12
    assert chart.runaway_n11.size >= 8


@pytest.mark.parametrize("field,value", [("d2", -1.0), ("k_incidence", float("nan")), ("opening_max", 80.0)])
def test_bad_parameters_are_rejected(field, value):
    with pytest.raises(InputError, match=field):
        FrancisParameters(**{field: value})


def test_out_of_domain_inputs_are_rejected():
    with pytest.raises(InputError, match="opening"):
        TURBINE.q11(60.0, 40.0)
    with pytest.raises(InputError, match="pumping"):
        TURBINE.q11(400.0, 20.0)


def test_compiled_kernel_is_the_same_model():
    """The simulator's kernel compiles the same equations: values and complex-step slopes equal the numpy methods
    to rounding (1e-12 of each quantity's scale); outside the domain it returns NaN (the loop reports it)."""
    turbine = SyntheticFrancis()
    kernel, params = turbine.numba_kernel()
    rng = np.random.default_rng(0)
    n11, a = rng.uniform(0.0, 120.0, 50), rng.uniform(0.0, turbine.opening_max, 50)
    got = np.array([kernel(params, x, y) for x, y in zip(n11, a)])
    want = np.column_stack([turbine.q11(n11, a), *turbine.q11_grad(n11, a), turbine.m11(n11, a),
                            *turbine.m11_grad(n11, a)])
    scale = np.abs(want).max(axis=0)
    assert np.all(np.abs(got - want) <= 1e-12 * scale)
    for outside in ((67.8, turbine.opening_max + 0.1), (-1.0, 10.0), (400.0, 10.0)):
        assert np.all(np.isnan(kernel(params, *outside)))


@pytest.mark.slow
def test_simulation_with_the_exact_turbine_is_compiled_and_equals_the_python_loop():
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 4.0,
                                      "scenario.event_time_s": 1.0})
    fast = run_simulation(plant, SyntheticFrancis())
    slow = run_simulation(plant, SyntheticFrancis(), jit=False)
    assert fast.meta["compiled"] and not slow.meta["compiled"]
    for name in ("speed_rpm", "head_m", "flow_m3_s"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * np.abs(b).max(), name  # same source; fused multiply-add may differ
