"""Scenarios on the synthetic Francis turbine and the ideal turbine; governor and rotor steps."""

from importlib import resources

import numpy as np
import pytest

from hillchart.synthetic.francis import SyntheticFrancis
from simulate.config import load_plant
from simulate.loop.engine import run_simulation
from simulate.components.control.governor import closure_law, governor_step
from simulate.components.schedules import piecewise_linear

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"
FRANCIS = SyntheticFrancis()


def plant(**overrides):
    return load_plant(PLANT_FILE, {"turbine.characteristics": "ideal", **overrides})


@pytest.fixture(scope="module")
def rejection():
    return run_simulation(plant(**{"scenario.t_end_s": 20.0}), FRANCIS)


def test_load_rejection_speed_rise_follows_the_swing_equation(rejection):
    r = rejection
    s = r.summary()
    # plausible guarantee figures for Ta = 9 s, 12 s full-stroke closure: speed rise 30-60 %, head rise 10-40 %
    assert 0.3 < s["max_speed_rise"] < 0.6 and 0.1 < s["max_head_rise"] < 0.4
    assert s["t_max_speed_s"] > 2.0  # after the breaker opens at 2 s
    # after the event the load is zero: x[k+1] - x[k] = dt/Ta * m_t[k] exactly (explicit Euler), so the speed
    # gain equals the summed turbine torque (checks event timing and the torque base P_r / omega_r)
    t = plant().turbine
    dt, ta = r.meta["dt_s"], 9.0
    k0 = int(np.searchsorted(r.time_s, 2.0 - 1e-9))
    x = r.speed_rpm / t.rated_speed_rpm - 1.0
    gain = dt / ta * np.sum(r.torque_nm[k0:-1] / t.rated_torque_nm)
    assert x[-1] - x[k0] == pytest.approx(gain, rel=1e-10)
    # before the event torque balances the load: speed constant to 1e-12
    assert np.max(np.abs(x[:k0])) < 1e-12
    # the governor closes at the rate limit: one full stroke per 12 s
    closing = np.diff(r.opening[k0:]) / dt
    assert closing.min() == pytest.approx(-1.0 / 12.0, rel=1e-9)


def test_closure_law_two_stage_is_followed_exactly():
    p = plant(**{"scenario.kind": "closure-law", "scenario.closing_time_s": 8.0, "scenario.break_opening": 0.3,
                 "scenario.break_time_s": 60.0, "scenario.t_end_s": 20.0})
    r = run_simulation(p, FRANCIS)
    y0 = r.opening[0]
    times, strokes = closure_law(y0, 2.0, 8.0, 0.3, 60.0)
    assert times[1] == pytest.approx(2.0 + (y0 - 0.3) * 8.0) and times[2] == pytest.approx(times[1] + 0.3 * 60.0)
    expected = np.array([piecewise_linear(times, strokes, t + 1e-9 * r.meta["dt_s"]) for t in r.time_s])
    assert np.max(np.abs(r.opening - expected)) < 1e-12
    # the slow second stage (18 s for the last 0.3 of stroke) is still under way at 20 s; one stage is done
    single = run_simulation(p.with_overrides({"scenario.break_opening": None, "scenario.break_time_s": None}),
                            FRANCIS)
    assert single.opening[-1] == 0.0 and r.opening[-1] > 0.0


def test_frequency_steps_track_the_reference():
    # no load, +4 %, -8 %, +4 % at 10, 40, 70 s: the governor holds the unit near no-load opening and brings the
    # speed back to rated (measured final error 1e-4; the -4 % level is not reached in 30 s since the closed
    # vanes only brake by disc friction, so only the +4 % plateau and the end are checked)
    r = run_simulation(plant(**{"scenario.kind": "frequency-steps", "scenario.t_end_s": 100.0}), FRANCIS)
    assert r.power_mw[0] == pytest.approx(0.0, abs=1e-9)  # no-load initial state
    at_35 = r.speed_rpm[np.searchsorted(r.time_s, 35.0)] / 200.0 - 1.0
    assert at_35 == pytest.approx(0.04, abs=0.005)
    assert abs(r.summary()["final_speed_error"]) < 1e-3
    assert r.summary()["max_speed_rise"] < 0.06


def test_load_step_dips_and_recovers():
    # grid-connected, +10 % load at 5 s, e_g = 1, no droop: speed dips, integral action restores it, and the
    # final turbine power is 1.1 times the initial (load torque 1.1 m0 at rated speed)
    r = run_simulation(plant(**{"scenario.kind": "load-step", "scenario.initial_power_mw": 180.0,
                                "scenario.event_time_s": 5.0, "scenario.t_end_s": 60.0}), FRANCIS)
    assert r.speed_rpm.min() < 199.0  # a dip of more than 0.5 %
    assert abs(r.summary()["final_speed_error"]) < 1e-3
    assert r.power_mw[-1] == pytest.approx(198.0, rel=5e-3)


def test_opening_steps_and_the_water_hammer_sign():
    r = run_simulation(plant(**{"scenario.kind": "opening-steps", "scenario.initial_power_mw": 180.0,
                                "scenario.opening_steps": [0.03, -0.03], "scenario.step_times_s": [2.0, 6.0],
                                "scenario.t_end_s": 10.0}), FRANCIS)
    y0 = r.opening[0]
    i2, i6 = np.searchsorted(r.time_s, 2.0 + 1e-6), np.searchsorted(r.time_s, 6.0 + 1e-6)
    assert r.opening[i2] == pytest.approx(y0 + 0.03, abs=1e-15) and r.opening[i6] == pytest.approx(y0, abs=1e-15)
    # opening the vanes drops the head (negative water hammer), closing them raises it
    assert r.head_m[i2] < r.head_m[i2 - 1] - 1.0 and r.head_m[i6] > r.head_m[i6 - 1] + 1.0
    assert np.allclose(r.opening_chart, r.opening * 32.0)


def test_governor_anti_windup_does_not_reverse_after_a_reference_step():
    # Saturated at the lower stroke limit by a large negative error with a derivative kick: the command must stay
    # at the limit while the kick decays (regression: back-calculation of the kick opened the vanes)
    params = np.array([2.0, 0.4, 0.5, 0.2, 0.0, 0.01, 0.0, 1.0, 0.9, 0.01, 0.01])
    state = np.zeros(3)
    commands = [governor_step(params, state, 0.04, -0.04, 0.0, 0.02) for _ in range(200)]
    assert max(commands) == 0.0
    # and a reversed error leaves saturation at once (the integral did not wind up beyond the stroke range)
    assert governor_step(params, state, -0.01, 0.0, 0.0, 0.02) > 0.0


def test_shipped_plant_with_its_nets_rejects_load_and_returns_to_rated_speed():
    # The example as shipped (nets.json, MOC, improved loop, compiled): the vanes shut at the closing-rate limit,
    # the shut boundary passes no flow (Q = 0 exactly, no iteration), the integral winds down during the overspeed
    # and the governor reopens to the no-load opening near rated speed (measured final error 1e-5 at 120 s).
    # The shipped nets carry the turbine's true zero-opening torque (K 1.1 x true, was 3.4 x): with the
    # vanes shut only disc friction brakes the runner, so at 120 s the unit is still decelerating. The final speed
    # must be the exact synthetic turbine's (measured: exact 0.2208 above rated); the nets' runaway/no-load region
    # decides it, so a wrong zero-opening boundary fails here. Since the silent-region samples (small openings) the
    # nets' torque at a = 0 sits 2-4 N*m below the truth at N11 60-100 (it was within 1 N*m; at a = 1-2 mm the
    # error fell from 4-16 to 1-4 N*m): measured nets 0.1785, a difference of 0.042; the bound is 0.05.
    from hillchart.synthetic.francis import SyntheticFrancis

    plant = load_plant(PLANT_FILE, {"scenario.t_end_s": 120.0})
    r = run_simulation(plant)
    assert r.meta["compiled"]
    s = r.summary()
    exact = run_simulation(plant, characteristics=SyntheticFrancis()).summary()
    assert 0.3 < s["max_speed_rise"] < 0.6 and abs(s["final_speed_error"] - exact["final_speed_error"]) < 0.05
    shut = r.opening <= 1e-6
    assert shut.sum() > 100 and np.all(r.flow_m3_s[shut] == 0.0) and np.all(r.iterations[shut] == 0)
    assert 0.0 < r.opening[-1] < 0.1  # no-load opening of the nets


def test_every_scenario_kind_says_what_happens_when_for_the_figures():
    """Each kind's events (what a report's transient figure marks): its event in words at event_time_s, or a step at
    each step time. A kind the report did not know by name (a start-up) raised AttributeError in the report."""
    from simulate.scenarios import SCENARIO_CLASSES, ScenarioConfig

    made = {"load-rejection": dict(initial_opening=0.8, event_time_s=2.0),
            "closure-law": dict(initial_opening=0.8, event_time_s=2.0, closing_time_s=8.0),
            "load-step": dict(initial_opening=0.8, event_time_s=2.0, load_step=-0.1),
            "frequency-steps": {}, "opening-steps": dict(initial_opening=0.8, opening_steps=(0.02, -0.02),
                                                        step_times_s=(1.0, 5.0)),
            "short-circuit": dict(event_time_s=2.0), "field-step": dict(event_time_s=2.0),
            "grid-frequency-step": dict(initial_opening=0.8, grid_frequency_steps=(0.01,), step_times_s=(3.0,)),
            "start-up": dict(event_time_s=2.0)}
    assert set(made) == set(SCENARIO_CLASSES)  # the check can fail: a new kind must say its events here
    events = {kind: ScenarioConfig(kind=kind, t_end_s=100.0, **keys).events() for kind, keys in made.items()}
    assert events["load-rejection"] == events["closure-law"] == [(2.0, "load rejection")]
    assert events["load-step"] == [(2.0, "load step -0.1")]
    assert events["frequency-steps"] == [(10.0, "step"), (40.0, "step"), (70.0, "step")]  # the defaults
    assert events["opening-steps"] == [(1.0, "step"), (5.0, "step")]
    assert events["grid-frequency-step"] == [(3.0, "step")]
    assert events["short-circuit"] == [(2.0, "three-phase fault")] and events["field-step"] == [(2.0, "field step")]
    assert events["start-up"] == [(2.0, "start")]
