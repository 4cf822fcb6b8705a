"""The shipped pump-turbine plant through its S-zone in both directions (benchmarks/bench_pump_turbine_transients.py):
a turbine-mode rejection and a pump trip, both with the vanes blocked, on the shipped Suter nets against the exact
synthetic machine through the same simulator, and at half the step. The bounds are the pump-turbine acceptance's:
max speed within 1 point, extreme heads within 2 % of the rated head, the runaway's period (and the flow reversal's
time) within 5 %; halving the step moves every figure by less than 0.5 %."""

import math
from pathlib import Path

import pytest
from tests.scripts import load_script

BENCH = Path(__file__).resolve().parents[3] / "benchmarks" / "bench_pump_turbine_transients.py"


@pytest.fixture(scope="module")
def bench():
    """The benchmark module, loaded from its file (each test worker loads it for itself)."""
    return load_script("bench_pump_turbine_transients")


@pytest.fixture(scope="module")
def measured(bench):
    return bench.measure()


def _figures(measured, case):
    return (measured[case][label][2] for label in ("nets", "exact", "half step"))


@pytest.mark.slow
@pytest.mark.parametrize("case", ["turbine-mode rejection", "pump trip"])
def test_nets_against_the_exact_machine_within_the_acceptance_bounds(measured, case):
    nets, exact, _ = _figures(measured, case)
    # the nets' runaway: within 0.2 point of the exact machine's (bound 1 point)
    assert abs(nets["max speed (% n_r)"] - exact["max speed (% n_r)"]) < 1.0
    for name in ("max head (% H_r)", "min head (% H_r)"):  # 0.1-0.5 % of H_r apart (bound 2 %)
        assert abs(nets[name] - exact[name]) < 2.0, name
    assert nets["flow reversal (s)"] == pytest.approx(exact["flow reversal (s)"], rel=0.05)  # 0.9 % and 0.1 %
    # time to runaway (the first speed peak): 5.67 against 5.62 s, 17.92 against 17.92 s
    assert nets["first speed peak (s)"] == pytest.approx(exact["first speed peak (s)"], rel=0.05)
    if case == "turbine-mode rejection":  # 12.25 s against 12.33 s; the pump trip holds one runaway peak in 30 s
        assert nets["runaway period (s)"] == pytest.approx(exact["runaway period (s)"], rel=0.05)
        assert 11.0 < nets["runaway period (s)"] < 13.5
    # the runaway is reached in both directions: a pump trip ends turning the runner as a turbine
    assert nets["max speed (% n_r)"] > 140.0
    assert nets["max reverse flow (m^3/s)"] > 5.0


@pytest.mark.slow
@pytest.mark.parametrize("case", ["turbine-mode rejection", "pump trip"])
def test_halving_the_step_moves_every_figure_by_less_than_half_a_percent(measured, case):
    nets, _, half = _figures(measured, case)
    for name, value in nets.items():
        if value is None or not math.isfinite(value):
            continue
        # measured from 40 to 80 reaches: at most 0.11 % (the rejection's runaway period, 12.246 against 12.259 s)
        assert half[name] == pytest.approx(value, rel=0.005, abs=1e-9), name


@pytest.mark.slow
def test_the_flow_reversal_time_converges_at_the_plant_step(bench):
    """The flow falls through zero within two steps where the path leaves the S-zone's turbine side: its time is
    first order in the step. 20 -> 40 reaches moves the rejection's flow reversal by 0.56 % (the failing case, which
    is why the plant has 40); 40 -> 80 by 0.04 % (8 s runs: past the reversal)."""
    times = [bench.figures(*bench.run("turbine-mode rejection", {"penstock.reaches": r, "scenario.t_end_s": 8.0}))
             ["flow reversal (s)"] for r in (20, 40, 80)]
    assert abs(times[1] / times[0] - 1) > 0.005  # the failing case: 20 reaches
    assert abs(times[2] / times[1] - 1) < 0.001


@pytest.mark.slow
def test_a_pump_trip_s_max_speed_rise_is_its_reverse_runaway(measured):
    """The summary's max speed rise is the largest speed in either direction over the initial |n0|: a pump trip
    starting at -n_r and running away at +1.479 n_r rises by 47.9 %, at the reverse runaway's peak (17.92 s). The
    failing case it replaces: max(n) / n0 - 1 of the signed speed gave -247.9 %."""
    plant, result, figures = measured["pump trip"]["nets"]
    summary = result.summary()
    assert result.speed_rpm[0] == pytest.approx(-plant.turbine.rated_speed_rpm, rel=1e-9)
    assert summary["max_speed_rise"] == pytest.approx(figures["max speed (% n_r)"] / 100 - 1, rel=1e-12)
    assert 0.45 < summary["max_speed_rise"] < 0.50
    assert summary["t_max_speed_s"] == pytest.approx(figures["first speed peak (s)"], abs=0.03)
    assert result.speed_rpm.max() / result.speed_rpm[0] - 1 < -2.4  # the signed reading it replaces


@pytest.mark.slow
@pytest.mark.parametrize("characteristics", [None, "synthetic-pump-turbine"])
def test_a_pump_mode_closure_to_zero_reaches_the_closed_vanes(bench, characteristics):
    """A closure-law run in pump mode (0.7 to 0 in 10 s) closes the vanes: below the curves' smallest opening (the
    nets' 4 mm, the exact table's 1 mm) the closed-vane model holds, and at the closed vanes there is no flow."""
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    overrides = {"turbine.operating_mode": "pump", "scenario.t_end_s": 12.0, "scenario.kind": "closure-law",
                 "scenario.closing_time_s": 10.0}
    if characteristics:
        overrides["turbine.characteristics"] = characteristics
    result = run_simulation(load_plant(bench.PLANT, overrides))
    assert result.success, result.message
    assert result.opening[-1] == 0.0 and result.flow_m3_s[-1] == 0.0


@pytest.mark.slow
def test_a_stroke_beyond_the_curves_largest_opening_stops_and_says_what_to_change(bench):
    """The failing case: the exact table ends at 28 mm; with 30 mm at full stroke an opening step from 0.9 (27 mm) by
    0.05 (to 28.5 mm) leaves it: the run stops, names the opening and what to change, and keeps the series."""
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    overrides = {"turbine.characteristics": "synthetic-pump-turbine", "turbine.opening_max": 30.0,
                 "scenario.kind": "opening-steps", "scenario.initial_opening": 0.9, "scenario.opening_steps": [0.05],
                 "scenario.step_times_s": [1.0], "scenario.t_end_s": 5.0, "governor.mode": "speed",
                 "governor.kp": 2.0, "governor.ki": 0.4, "governor.kd": 0.0, "governor.derivative_filter_s": 0.0,
                 "governor.permanent_droop": 0.0}
    result = run_simulation(load_plant(bench.PLANT, overrides), raise_on_failure=False)
    assert not result.success
    assert "opening outside the curves' openings" in result.message and "largest opening" in result.message
    assert 0.9 <= result.opening[-1] <= 28.0 / 30.0 and result.time_s[-1] > 0.9  # the series up to the step
