"""Runs that cannot finish, cannot fit or cannot be trusted are refused before they start; long runs can be decimated
and interrupted, with messages that name what to change."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

ROOT = Path(__file__).resolve().parents[3]
IDEAL = {"turbine.characteristics": "ideal"}


def test_a_step_long_against_the_inertia_time_is_refused_naming_it():
    """A 22.5 s MOC step is refused (wave speed 1 m/s once gave '3 steps of 22.5 s, max speed rise 250 %'; such a
    wave speed is now refused by the plant file, an 18 km pipe gives the same step)."""
    plant = load_plant(PLANT_HLA339, {**IDEAL, "penstock.segments": [
        {"length_m": 18000.0, "diameter_m": 5.6, "wave_speed_m_s": 100.0, "darcy_friction": 0.0}]})
    with pytest.raises(InputError, match=r"time step dt = 22\.5 s is not small against generator\.inertia_time_s "
                                         r"\(Ta\) = 9 s \(allowed dt <= 0\.5 x 9 = 4\.5 s\)"):
        run_simulation(plant)


def test_a_blade_servo_of_a_millisecond_warns_naming_the_plausible_range():
    """blade_servo.servo_time_s = 1 ms (a value in ms?) warns; the bulb example's 1 s does not."""
    from data_synthetic import PLANT_BULB
    from simulate.loop.guards import plausibility_warnings

    assert plausibility_warnings(load_plant(PLANT_BULB)) == []
    (line,) = plausibility_warnings(load_plant(PLANT_BULB, {"blade_servo.servo_time_s": 0.001}))
    assert line.startswith("blade_servo.servo_time_s = 0.001 s is implausibly short") and "0.5-60 s" in line
    assert "check the value and its unit (s, not ms)" in line


def test_a_full_stroke_or_a_rated_speed_in_another_unit_than_the_chart_is_named():
    """The turbine section against the nets' digitized region (the shipped chart: lines up to 32 mm, N11
    43.8-88.3). The shipped plant (opening_max 32, rated N11 67.8) and a full stroke a third beyond the lines (43)
    say nothing. An opening_max of 100, as if in %, ran without a word on the cause: the initial power sat at a fifth
    of the stroke, the closure took 2.6 s and the head rose by 119 % (a warning of the run now names it). 10 mm, as
    if the chart were in cm, and a rated speed of 20.94 (rad/s for 200 r/min: N11 7.1) leave the rated power out of
    reach, and the error about the power range now ends with the note that names the cause."""
    from simulate.components.turbine.component import characteristics_of
    from simulate.loop.guards import characteristics_warnings
    from simulate.loop.prepare import initial_state

    def warnings_of(**values):
        plant = load_plant(PLANT_HLA339, {f"turbine.{k}": v for k, v in values.items()})
        return characteristics_warnings(plant.turbine, characteristics_of(plant))

    assert warnings_of() == [] and warnings_of(opening_max=43.0) == []
    assert warnings_of(opening_max=100.0) == [
        "turbine.opening_max = 100 (the chart opening at full stroke) is 3.12 times the largest digitized opening "
        "line of the characteristics, 32 mm: the full stroke reads the nets far above every digitized line. Give "
        "turbine.opening_max in the chart's opening unit (mm), as the opening the guide vanes reach at full servo "
        "stroke"]
    (low,) = warnings_of(opening_max=10.0)
    assert "0.312 times the largest digitized opening line" in low and "far below the chart's upper lines" in low
    (speed,) = warnings_of(rated_speed_rpm=20.94)
    assert speed.startswith("the rated unit speed N11 = n D / sqrt(H) = 7.103 r/min (turbine.rated_speed_rpm = "
                            "20.94,") and "digitized lines' N11, 43.8-88.27 r/min" in speed
    assert characteristics_warnings(load_plant(PLANT_HLA339, IDEAL).turbine, "ideal") == []  # no digitized region
    meta = run_simulation(load_plant(PLANT_HLA339, {"turbine.opening_max": 100.0, "scenario.t_end_s": 3.0})).meta
    assert warnings_of(opening_max=100.0)[0] in meta["warnings"]
    for key, value, note in (("opening_max", 10.0, r"turbine\.opening_max = 10 .* 0\.312 times"),
                             ("rated_speed_rpm", 20.94, r"the rated unit speed N11 = n D / sqrt\(H\) = 7\.103")):
        with pytest.raises(InputError, match=r"is outside the power range the unit gives .*\. Note: " + note):
            initial_state(load_plant(PLANT_HLA339, {f"turbine.{key}": value}))


def test_a_static_head_far_from_the_rated_head_warns():
    """penstock.static_head_m 10 x the rated head (1765 for 176.5, as if in kPa) ran with the rated power at 3 % of
    the stroke and a max speed rise of 3 %, with no word on the head; it warns now. The shipped plants (0.77-1.08
    times) and 1.5 x do not."""
    from simulate.loop.guards import plausibility_warnings

    assert plausibility_warnings(load_plant(PLANT_HLA339, {"penstock.static_head_m": 264.0})) == []
    # the 500 m penstock is then shorter than the head too (test_a_waterway_shorter_than_its_head_warns)
    waterway, line = plausibility_warnings(load_plant(PLANT_HLA339, {"penstock.static_head_m": 1765.0}))
    assert line.startswith("penstock.static_head_m = 1765 m is 10 times turbine.rated_head_m = 176 m")
    assert "(m of water, not kPa)" in line and waterway.startswith("the waterway is 500 m long")


def test_a_waterway_shorter_than_its_head_warns():
    """A penstock of 0.5 m (km for m) for 180 m of head ran 358400 steps of 56 us and gave a head rise of 0.02 %
    without a word; it warns now. The shipped plant's 500 m, and its surge-tank variant with the 1000 m tunnel, do
    not; 170 m of penstock (shorter than the head) does."""
    from simulate.loop.guards import plausibility_warnings

    def short(length_m):
        return {"penstock.segments": [{"length_m": length_m, "diameter_m": 6.2, "wave_speed_m_s": 1120.0,
                                       "darcy_friction": 0.012}]}

    assert plausibility_warnings(load_plant(PLANT_HLA339)) == []
    assert plausibility_warnings(load_plant(PLANT_HLA339.with_name("plant_hla339_surge_tank.toml"))) == []
    (line,) = plausibility_warnings(load_plant(PLANT_HLA339, short(0.5)))
    assert line.startswith("the waterway is 0.5 m long (the penstock's segments and any headrace tunnel), shorter "
                           "than the 180 m of head it drops") and "(m, not km)" in line
    assert len(plausibility_warnings(load_plant(PLANT_HLA339, short(170.0)))) == 1


def test_coarse_rigid_step_is_refused_and_a_moderate_one_warned():
    """A rigid penstock with dt_s = 10 is refused (it once gave '6 steps of 10 s, max speed rise 111 %')."""
    with pytest.raises(InputError, match=r"dt = 10 s is not small against penstock water time Tw .* = 1\.47\d* s "
                                         r"\(allowed dt <= 0\.5 x"):
        run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 10.0}))
    # Tw of the shipped plant is about 1.5 s, the servo time 0.2 s: dt = 1 s is refused naming Tw (coupled with the
    # hydraulics every step); dt = 0.5 s runs (the servo is an exact exponential at any step) with warnings naming
    # the servo and Tw and the key to change; dt = 0.05 s warns about the servo and the derivative filter only
    # (> 0.1 x 0.2 s); 0.01 s is quiet (the derivative filter is resolved at 0.05 x 0.2 s)
    with pytest.raises(InputError, match=r"dt = 1 s is not small against penstock water time Tw"):
        run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 1.0,
                                                 "generator.inertia_time_s": 30.0}))
    r = run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 0.5,
                                                 "scenario.t_end_s": 10.0}))
    warned = r.summary()["warnings"]
    assert any("more than 0.1 x governor.servo_time_s = 0.2 s" in w and "set solver.dt_s so that dt <= 0.02 s" in w
               for w in warned)
    assert any("more than 0.1 x penstock water time Tw" in w for w in warned)
    r = run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 0.05,
                                                 "scenario.t_end_s": 10.0}))
    steps = [w for w in r.summary()["warnings"] if "time step" in w]
    assert len(steps) == 2 and "more than 0.1 x governor.servo_time_s" in steps[0] and \
        "more than 0.05 x governor.derivative_filter_s" in steps[1]
    r = run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "rigid", "solver.dt_s": 0.01,
                                                 "scenario.t_end_s": 10.0}))
    assert not any("time step" in w for w in r.summary()["warnings"])


def test_a_fast_servo_on_the_moc_grid_is_sub_stepped_not_refused():
    # servo 0.02 s against the grid's 0.0191 s: the governor and the rotor run 10 sub-steps per MOC step (0.1 x
    # 0.02 s each), silently; the result agrees with a grid 10 x finer (80 reaches, no sub-steps) to 0.1 point of
    # speed and head rise (the step-convergence bound; measured 0.08 point of a 60 % rise: what is left is the
    # hydraulic step itself, the coarse grid hands the servo's opening to the turbine once per 19 ms)
    over = {**IDEAL, "governor.servo_time_s": 0.02, "scenario.t_end_s": 15.0}
    coarse = run_simulation(load_plant(PLANT_HLA339, over))
    assert coarse.meta["substeps"] == 10 and not any("time step" in w for w in coarse.summary()["warnings"])
    fine = run_simulation(load_plant(PLANT_HLA339, {**over, "penstock.reaches": 80}))
    assert fine.meta["substeps"] == 1
    a, b = coarse.summary(), fine.summary()
    assert abs(a["max_speed_rise"] - b["max_speed_rise"]) < 1e-3
    assert abs(a["max_head_rise"] - b["max_head_rise"]) < 1e-3


def test_huge_runs_are_refused_with_the_estimate_and_the_key():
    """10 000 reaches and t_end 1e5 s are refused before allocating (they once tried to allocate 48.8 GiB)."""
    plant = load_plant(PLANT_HLA339, {**IDEAL, "penstock.reaches": 10000, "scenario.t_end_s": 1e5})
    with pytest.raises(InputError, match=r"the run needs 6\.55\d*e\+09 steps x \(\d+ nodes \+ 100 for the step\) = "
                                         r".* more than solver\.max_node_steps = 3e\+10.*raise solver\.max_node_steps"):
        run_simulation(plant)
    # a tiny lumped step: few nodes, but 6e7 rows would take 4 GB
    plant = load_plant(PLANT_HLA339, {**IDEAL, "penstock.model": "lumped", "solver.dt_s": 1e-6})
    with pytest.raises(InputError, match=r"the stored series would take about 4\d\d\d MB \(60000001 rows\), more than "
                                         r"solver\.max_output_mb = 2000: set solver\.output_dt_s"):
        run_simulation(plant)


def test_limits_are_overridable_and_output_dt_decimates_exactly():
    full = run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 10.0}))
    dt = full.meta["dt_s"]
    plant = load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 10.0, "solver.output_dt_s": 4 * dt,
                                      "solver.max_output_mb": 0.01})
    thin = run_simulation(plant)
    # the same arithmetic: every 4th row of the full run, bit for bit
    for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
        np.testing.assert_array_equal(getattr(thin, name), getattr(full, name)[::4][:thin.time_s.size])
    assert thin.meta["output_dt_s"] == 4 * dt and thin.time_s.size == full.time_s.size // 4 + 1
    # the envelope still sees every step
    np.testing.assert_array_equal(thin.envelope_max_m, full.envelope_max_m)
    with pytest.raises(InputError, match=r"stored series would take about 0\.0\d+ MB"):
        run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 10.0, "solver.max_output_mb": 0.01}))
    with pytest.raises(InputError, match=r"solver\.output_dt_s = 0\.05 s must be a whole multiple of the time step"):
        run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "solver.output_dt_s": 0.05}))


@pytest.mark.parametrize("key,value,message", [
    ("output_dt_s", -1.0, r"solver\.output_dt_s must be in \(0\.0, 10000\.0\]"),
    ("max_node_steps", 0, r"solver\.max_node_steps must be in \(0\.0, 1000000000000000\.0\]"),
    ("max_output_mb", "lots", r"solver\.max_output_mb must be a number"),
])
def test_solver_limit_garbage(key, value, message):
    with pytest.raises(InputError, match=message):
        load_plant(PLANT_HLA339, {f"solver.{key}": value})


def test_ctrl_c_stops_a_long_run_within_about_a_second(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    base = [sys.executable, "-m", "hillsim.cli", "run", str(PLANT_HLA339), "--no-plot", "--set",
            "turbine.characteristics=ideal", "--set", "penstock.reaches=800"]
    # warm the compiled-loop cache with a short run of the same combination
    subprocess.run(base + ["--out", str(tmp_path / "warm"), "--set", "scenario.t_end_s=3"], env=env, check=True,
                   capture_output=True, timeout=600)
    dt = (180.0 / 1180.0) / 800
    proc = subprocess.Popen(base + ["--out", str(tmp_path / "long"), "--set", "scenario.t_end_s=1000", "--set",
                                    f"solver.output_dt_s={100 * dt!r}"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # the stage line comes after imports and the steady state; then the cached loop loads and runs for minutes
    assert proc.stderr.readline().startswith("simulating load-rejection, 1000 s")
    time.sleep(2.0)
    assert proc.poll() is None
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    waited = time.perf_counter() - sent
    assert proc.returncode == 130, err
    # one line about the interrupt (a progress line may precede it on a non-terminal)
    last = err.strip().splitlines()[-1]
    assert "interrupted" in last and "no outputs written" in last and err.count("interrupted") == 1
    assert "Traceback" not in err
    assert not (tmp_path / "long").exists()
    # chunks of about 0.25 s of work: honoured within about a second (3 s allowed on a loaded 2-core machine)
    print(f"Ctrl-C honoured after {waited:.2f} s")
    assert waited < 3.0, waited


def test_absurd_penstock_gives_a_clean_error_not_a_math_domain_error():
    """A penstock of 1e9 m is refused by name (it once ended in 'math domain error' in the steady state)."""
    with pytest.raises(InputError, match=r"penstock\.segments\.length_m must be in \(0\.0, 100000\.0\], "
                                         r"got 1000000000\.0 "
                                         r"\(segment 0"):
        load_plant(PLANT_HLA339, {"penstock.segments": [
            {"length_m": 1e9, "diameter_m": 6.0, "wave_speed_m_s": 1100.0, "darcy_friction": 0.012}]})
    # the longest allowed pipe, narrow and rough: the friction loss dwarfs the static head
    plant = load_plant(PLANT_HLA339, {**IDEAL, "penstock.segments": [
        {"length_m": 1e5, "diameter_m": 0.5, "wave_speed_m_s": 1100.0, "darcy_friction": 0.2}]})
    with pytest.raises(InputError, match=r"steady state: .* friction loss K Q\|Q\| = .* is not small against "
                                         r"penstock\.static_head_m: no plausible steady flow; check the penstock "
                                         r"segments' length_m, diameter_m and darcy_friction"):
        run_simulation(plant)


@pytest.mark.parametrize("key", ["governor.kp", "governor.derivative_filter_s", "governor.servo_time_s"])
def test_a_time_scale_needing_astronomic_sub_steps_is_refused_by_the_run_size_check(key):
    """1e-300 for a gain or a time constant of the governor asked for about 1e299 sub-steps a step: the count, a
    Python integer too large for the compiled loop, escaped as a numba typing error. The run-size check now counts the
    sub-steps; the shipped plant's sub-steps pass it."""
    assert run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 2.5})).meta["substeps"] >= 1
    with pytest.raises(InputError, match=r"the run needs 131 steps of \d\.\d+e\+29\d sub-steps each for the control "
                                         r"and the shaft .* more than solver\.max_node_steps = 3e\+10: a time scale "
                                         r"of the governor or the generator"):
        run_simulation(load_plant(PLANT_HLA339, {**IDEAL, "scenario.t_end_s": 2.5, key: 1e-300}))
