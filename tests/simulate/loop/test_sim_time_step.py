"""The time step and the solver follow the physics: the step from the components' time scales, events at their times,
a pressure loop that does not fail on a hair, and the step-convergence table in the docs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from data_synthetic import PLANT_HLA339, PLANT_HLA339_GRID
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                             ScenarioConfig, TurbineConfig, load_plant)
from simulate.loop.engine import run_simulation
from simulate.loop.timestep import aligned_step
from simulate.studies.step_check import check_step
from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[3]
IDEAL = {"turbine.characteristics": "ideal"}


def tnet0_plant(reaches: int) -> PlantConfig:
    """TSNet's example network Tnet0: reservoir at 750 m; 1200 m of 0.6 m pipe (Darcy 0.018) then 1200 m of 1.2 m
    pipe (0.021), a = 1200 m/s; 50 l/s through an end valve (the ideal turbine: Q proportional to the opening times
    sqrt(H)) closed linearly in 2 s from t = 0."""
    q0, h0 = 0.05, 750.0
    turbine = TurbineConfig(rated_head_m=h0, rated_flow_m3_s=q0, rated_speed_rpm=300.0,
                            rated_power_mw=0.9 * 9.81 * q0 * h0 / 1e3, runner_diameter_m=0.158, opening_max=1.0,
                            characteristics="ideal")
    segments = (PenstockSegment(length_m=1200.0, diameter_m=0.6, wave_speed_m_s=1200.0, darcy_friction=0.018),
                PenstockSegment(length_m=1200.0, diameter_m=1.2, wave_speed_m_s=1200.0, darcy_friction=0.021))
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
                              servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    return PlantConfig(turbine=turbine,
                       penstock=PenstockConfig(model="moc", static_head_m=h0, reaches=reaches, segments=segments,
                                               friction_model="steady"),  # as the reference code ran it
                       generator=GeneratorConfig(inertia_time_s=8.0), governor=governor,
                       scenario=ScenarioConfig(kind="closure-law", t_end_s=60.0, initial_opening=1.0,
                                               event_time_s=0.0, closing_time_s=2.0))


def test_tnet0_two_pipe_valve_runs_on_ten_reaches_without_warning():
    # the valve's max / min head of a commercial code: 761.8 / 738.3 m; +-0.3 m is the promised bound (the closure
    # takes 2 s against 1 s of travel per pipe, so 10 reaches per pipe resolve it). The MOC is exact on its grid: a
    # rigid-column yardstick (Tw = 0.04 s here) does not apply and nothing is refused or warned.
    run = run_simulation(tnet0_plant(10))
    assert run.meta["dt_s"] == pytest.approx(0.1, rel=1e-12) and run.meta["substeps"] == 1
    assert run.summary()["warnings"] == []
    assert run.head_m.max() == pytest.approx(761.8, abs=0.3)
    assert run.head_m.min() == pytest.approx(738.3, abs=0.3)
    # five times the reaches: the same extremes to 0.01 m (measured 0.001 and 0.02 m... the grid is converged)
    fine = run_simulation(tnet0_plant(50))
    assert abs(fine.head_m.max() - run.head_m.max()) < 0.01
    assert abs(fine.head_m.min() - run.head_m.min()) < 0.05


def _exact_fault_current(gen, e0, tau):
    """|I| of eq. (10) after a terminal fault from open circuit (Ra = 0, field held), by the matrix exponential."""
    a = np.array([[-1.0 / gen.td0_t_s, -(gen.xd - gen.xd_t) / (gen.xd_st * gen.td0_t_s)],
                  [1.0 / gen.td0_st_s, -(1.0 + (gen.xd_t - gen.xd_st) / gen.xd_st) / gen.td0_st_s]])
    m = np.zeros((3, 3))
    m[:2, :2], m[:2, 2] = a, [e0 / gen.td0_t_s, 0.0]
    return np.array([(expm(m * x) @ [e0, e0, 1.0])[1] for x in tau]) / gen.xd_st


@pytest.mark.parametrize("model", ["rigid", "moc"])
def test_default_short_circuit_matches_eq10_from_5_ms_and_starts_at_the_event(model):
    # the sub-transient generator of Table 1 (generator_table1.toml's constants in the grid plant), fault at 0.5 s,
    # default solver settings. Rigid: the step is chosen from T''q (1.04 ms) and put on the event; MOC: the grid's
    # 19 ms step, the generator sub-stepped and its step split at the fault. The promised bound is 1 % from 5 ms
    # after the fault; measured 6e-10 (RK4 error only). Before: 43 ms steps, the fault at 0.522 s, 4.8 % off.
    plant = load_plant(PLANT_HLA339_GRID, {**IDEAL, "penstock.model": model, "scenario.kind": "short-circuit",
                                           "scenario.event_time_s": 0.5, "scenario.t_end_s": 1.5})
    run = run_simulation(plant)
    t = run.time_s
    current = np.hypot(run.signals["current_d_pu"], run.signals["current_q_pu"])
    first = t[np.nonzero(current)[0][0]]
    if model == "rigid":
        assert first == pytest.approx(0.5, abs=1e-12) and run.meta["dt_s"] < 1.1e-3
    else:  # the first sample of the grid after the fault
        assert 0.5 < first <= 0.5 + run.meta["dt_s"] and run.meta["substeps"] >= 10
    after = t >= 0.5 + 5e-3
    exact = _exact_fault_current(plant.generator.subtransient, run.signals["terminal_voltage_pu"][0],
                                 t[after] - 0.5)
    assert np.max(np.abs(current[after] / exact - 1.0)) < 1e-6
    assert run.summary()["warnings"] == []


def test_events_fall_on_the_step_when_the_solver_chooses_it():
    assert aligned_step(0.043, [0.5]) == pytest.approx(0.5 / 12, rel=1e-15)
    assert aligned_step(0.02, [2.0, 40.0, 70.5]) == pytest.approx(0.5 / 25, rel=1e-15)
    # no common step within a factor 4: left alone (the components split their steps at the event instead)
    assert aligned_step(0.02, [1.0000001]) == 0.02
    run = run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "scenario.t_end_s": 5.0,
                                                   "scenario.event_time_s": 1.234}))
    dt = run.meta["dt_s"]
    assert abs(1.234 / dt - round(1.234 / dt)) < 1e-9 and run.meta["aligned_event_times_s"] == [1.234]
    # the rotor sees the rejection from 1.234 s on: the speed leaves rated on the first step after it
    moved = run.time_s[np.nonzero(run.speed_rpm != run.speed_rpm[0])[0][0]]
    assert moved == pytest.approx(1.234 + dt, abs=1e-9)


def test_an_event_between_the_steps_of_a_fixed_dt_is_reported_and_recorded():
    """With solver.dt_s = 0.05 an event at 1.234 s acts from 1.25 s (the next step): a warning names both times and
    how to align, meta records the move; an event at 1.25 s (a whole step) is neither."""
    base = {**IDEAL, "penstock.model": "rigid", "scenario.t_end_s": 2.0, "solver.dt_s": 0.05}
    on = run_simulation(load_plant(PLANT_HLA339, {**base, "scenario.event_time_s": 1.25}))
    assert on.meta["moved_event_times_s"] == [] and not any("scenario event" in w for w in on.summary()["warnings"])
    run = run_simulation(load_plant(PLANT_HLA339, {**base, "scenario.event_time_s": 1.234}))
    (move,) = run.meta["moved_event_times_s"]
    assert move["requested_s"] == 1.234 and move["acts_from_s"] == pytest.approx(1.25, abs=1e-12)
    (line,) = [w for w in run.summary()["warnings"] if "scenario event" in w]
    assert ("scenario event(s) at 1.234 s fall between steps of solver.dt_s = 0.05 s and act from 1.25 s (the next "
            "step)") in line and "set solver.dt_s = 0.0493" in line, line  # 1.234 / 25 = 0.04936
    # what the record says is what ran: the speed leaves rated one step after 1.25 s, as with the event at 1.25 s
    first = run.time_s[np.nonzero(run.speed_rpm != run.speed_rpm[0])[0][0]]
    assert first == pytest.approx(1.25 + 0.05, abs=1e-9)
    np.testing.assert_array_equal(run.speed_rpm, on.speed_rpm)


@pytest.mark.slow
def test_the_moc_grid_step_given_as_solver_dt_s_runs_as_without_it_and_warns_of_no_event():
    """With MOC, solver.dt_s can only be the grid's own step (the step hillsim prints, 0.0190678 s): the event at 2 s
    acts where it does without the key, so there is nothing to report. It was warned as falling between the steps,
    advising a step (0.0190476 s) the Courant condition refuses and 'leave solver.dt_s out', which changes nothing."""
    base = {**IDEAL, "scenario.t_end_s": 2.5}
    default = run_simulation(load_plant(PLANT_HLA339, base))
    printed = run_simulation(load_plant(PLANT_HLA339, {**base, "solver.dt_s": float(f"{default.meta['dt_s']:.6g}")}))
    assert printed.meta["dt_s"] == default.meta["dt_s"] and 2.0 / default.meta["dt_s"] % 1 > 1e-3  # not on a step
    assert printed.meta["moved_event_times_s"] == [] == default.meta["moved_event_times_s"]
    assert printed.summary()["warnings"] == default.summary()["warnings"] == []
    np.testing.assert_array_equal(printed.speed_rpm, default.speed_rpm)


@pytest.mark.parametrize("loop", ["improved", "newton", "traditional"])
def test_rigid_penstock_at_a_tenth_of_a_millisecond_runs_with_every_pressure_loop(loop):
    # |k Q| ~ 2.6e6 m on the rigid column at dt = 1e-4 s: the head is known to ~1e-9 m only. A fixed tolerance of
    # 1e-10 x 176 m could not be met (the loop "failed" in steady state); the round-off floor of the tolerance and
    # the stable root of eq. (32) let every loop run at its default settings, and all three give the same figures
    plant = load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 1e-4,
                                      "scenario.t_end_s": 3.0, "solver.pressure_loop": loop})
    run = run_simulation(plant)
    assert run.success
    reference = run_simulation(plant.with_overrides({"solver.pressure_loop": "newton"}))
    assert run.summary()["max_speed_rise"] == pytest.approx(reference.summary()["max_speed_rise"], abs=1e-9)


@pytest.mark.parametrize("family", ["slow", "medium", "fast"])
def test_family_rejections_at_60_to_100_percent_load_need_no_setting(family):
    # every family turbine (the exact characteristics the family charts are drawn from) on the shipped plant's
    # waterway, rated at its full-stroke point there; rejections from 100, 80 and 60 % load with default solver
    # settings: no pressure-loop failure (and no fallback needed)
    from hillchart.synthetic.francis import family_turbine
    from simulate.loop.engine import initial_state

    turbine = family_turbine(family).turbine()
    plant = load_plant(PLANT_HLA339, {**IDEAL, "turbine.opening_max": turbine.opening_max, "scenario.t_end_s": 20.0,
                                      "scenario.initial_power_mw": None, "scenario.initial_opening": 1.0})
    full = initial_state(plant, turbine)
    for load in (1.0, 0.8, 0.6):
        run = run_simulation(plant.with_overrides({
            "turbine.rated_power_mw": full.power_mw, "turbine.rated_flow_m3_s": full.flow_m3_s,
            "scenario.initial_opening": None, "scenario.initial_power_mw": load * full.power_mw}),
            characteristics=turbine, raise_on_failure=False)
        assert run.success, (family, load, run.message)
        assert run.meta["pressure_loop_fallback_steps"] == 0


def test_check_step_refuses_up_front_a_half_step_rerun_beyond_the_reaches_bound(tmp_path, capsys):
    """penstock.reaches = 10000 with --check-step once ran, then refused its own rerun at 20000 reaches: now refused
    before the run with what to set; 5000 (rerun at 10000) passes the check."""
    from hillsim.cli import main
    from simulate.studies.step_check import check_halving_allowed

    check_halving_allowed(load_plant(PLANT_HLA339, {"penstock.reaches": 5000}))  # the rerun's 10000 is allowed
    out = tmp_path / "out"
    code = main(["run", str(PLANT_HLA339), "--set", "penstock.reaches=10000", "--check-step", "--out", str(out),
                 "--quiet", "--no-plot"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert ("--check-step reruns at half the step, with penstock.reaches = 20000 (twice 10000), which is refused "
            "(penstock.reaches must be an integer in [1, 10000], got 20000); set penstock.reaches <= 5000") in err
    assert "simulating" not in err  # nothing ran


def test_check_step_reports_the_change_of_each_figure():
    plant = load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 10.0})
    run = run_simulation(plant)
    check = check_step(plant, run)
    assert check["half_dt_s"] == pytest.approx(run.meta["dt_s"] / 2, rel=1e-12)  # 16 reaches instead of 8
    fig = check["figures"]["max_speed_rise"]
    assert fig["unit"] == "points" and fig["change"] == pytest.approx(100 * (fig["half_step"] - fig["value"]))
    # the shipped plant is step-converged: well inside 0.1 point; a coarse user step is not (the check can fail)
    assert check["max_change_points"] < 0.1
    coarse = plant.with_overrides({"penstock.model": "rigid", "solver.dt_s": 0.2})
    assert check_step(coarse, run_simulation(coarse))["max_change_points"] > 0.1


@pytest.mark.slow
def test_the_time_step_page_is_what_the_benchmark_prints():
    bench = load_script("bench_time_step")
    page = (ROOT / "docs" / "time-step.md").read_text(encoding="utf-8")
    rows = bench.table_rows()
    # the figures agree to the printed digits on any machine (the runs are deterministic; printed to 1e-4 point)
    assert bench.DOC_HEAD + bench.markdown(rows) == page


def test_solver_fallback_garbage_is_named():
    from hillchart.errors import InputError

    with pytest.raises(InputError, match=r"solver\.fallback must be true or false, got 'yes'"):
        load_plant(PLANT_HLA339, {"solver.fallback": "yes"})


def test_user_substeps_that_leave_a_component_unresolved_are_a_warning_naming_the_key():
    # the grid plant's generator wants 0.1 x T''q = 1.04 ms: 19 sub-steps of the 19 ms grid; one is warned about,
    # naming the constant and the count that resolves it; the chosen count is quiet
    over = {**IDEAL, "scenario.kind": "short-circuit", "scenario.event_time_s": 0.5, "scenario.t_end_s": 1.0}
    quiet = run_simulation(load_plant(PLANT_HLA339_GRID, over))
    assert quiet.meta["substeps"] == 19 and quiet.summary()["warnings"] == []
    forced = run_simulation(load_plant(PLANT_HLA339_GRID, {**over, "solver.substeps": 1}))
    assert forced.meta["substeps"] == 1
    assert any("0.1 x generator sub-transient q-axis time T''q" in w and "raise solver.substeps to 19" in w
               for w in forced.summary()["warnings"])
