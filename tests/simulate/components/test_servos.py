"""The guide-vane servos (registry kind "servo", governor.servo_model): closed-form responses of each component
and of the plant loop that runs it.

* rate limit: a load rejection closes the vanes at exactly one full stroke per closing_time_s;
* dead time: the response is the delay-free one shifted by the dead time;
* backlash: the vanes follow the piston less half the play once it is taken up, and hold while the piston moves
  inside it;
* two-stage closing: a load rejection closes the vanes along the two-stage law of the closure-law scenario
  (:func:`simulate.components.control.governor.closure_law`), exactly;
* rate limit (the ramp limiter, no lag): a closure runs at one full stroke per closing_time_s exactly, down to the
  closed end; a command within one step's travel is reached in that step; in a plant's load rejection the vanes
  close on that ramp to the closed end;
* backlash in a plant's load rejection: the vanes are the first-order servo's stroke plus half the play, exactly,
  and stop half the play short of the closed end.
"""

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.components.control.backlash import backlash_servo_step
from simulate.components.control.dead_time import dead_time_servo_step, delay_steps
from simulate.components.control.servo import first_order_servo_step
from simulate.components.registry import SERVOS

#: first-order servo vector (simulate.components.control.servo.SERVO_PARAMS): stroke 0-1, T_y with dt / T_y = 0.1,
#: a full stroke in 10 s closing / 20 s opening at dt = 0.02 s
FIRST_ORDER = np.array([0.0, 1.0, np.exp(-0.1), 0.02 / 10.0, 0.02 / 20.0])


def _commands(n=400, seed=0):
    """A command sequence: rest at 0.6, a step to 0.3, then a seeded random walk inside the stroke range."""
    rng = np.random.default_rng(seed)
    walk = np.clip(0.3 + np.cumsum(rng.normal(0.0, 0.01, n - 50)), 0.05, 0.95)
    return np.concatenate([np.full(20, 0.6), np.full(30, 0.3), walk])


def _respond(step, sp, ss, commands, y0):
    out, y = [], y0
    for c in commands:
        y = step(sp, ss, c, y, 0.02)
        out.append(y)
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1])
def test_dead_time_response_is_the_delay_free_one_shifted_by_the_dead_time(seed):
    commands = _commands(seed=seed)
    free = _respond(first_order_servo_step, FIRST_ORDER, np.zeros(1), commands, 0.6)
    n = delay_steps(0.14, 0.02)
    assert n == 7
    state = np.full(n + 1, 0.6)
    state[0] = 0.0
    delayed = _respond(dead_time_servo_step, FIRST_ORDER, state, commands, 0.6)
    # the same arithmetic on the same commands n steps later: equal to the last bit (tolerance 0)
    np.testing.assert_array_equal(delayed[:n], 0.6)
    np.testing.assert_array_equal(delayed[n:], free[:-n])
    # beside it, a shift by one step less is not the response (the step to 0.3 moves 0.002 per step at the limit)
    assert np.max(np.abs(delayed[n:] - free[1:1 - n])) > 1e-3


def test_backlash_follows_the_closed_form_dead_band_response():
    """Piston = command (no lag: decay 0; no rate limit), play b = 0.06: up a ramp 0.5 -> 0.7 the vanes stay until
    the piston is b/2 above them, then follow at piston - b/2; back down they hold at 0.67 until the piston is b/2
    below, then follow at piston + b/2."""
    b = 0.06
    sp = np.array([0.0, 1.0, 0.0, np.inf, np.inf, b / 2])
    up = 0.5 + 0.01 * np.arange(1, 21)
    down = 0.7 - 0.01 * np.arange(1, 31)
    commands = np.concatenate([up, down])
    vanes = _respond(backlash_servo_step, sp, np.array([0.5]), commands, 0.5)
    expected = np.concatenate([np.maximum(0.5, up - b / 2), np.minimum(0.7 - b / 2, down + b / 2)])
    # closed form on sums of 0.01 steps: equal within rounding (1e-12 is 1e4 ulps of the strokes, far below the
    # 0.01 a wrong engagement point would show)
    np.testing.assert_allclose(vanes, expected, rtol=0, atol=1e-12)
    assert vanes[1] == 0.5 and vanes[3] == pytest.approx(0.51, abs=1e-12)  # engages after b/2 = 0.03 of travel
    assert np.all(vanes[20:23] == vanes[19])  # holds at the reversal while the piston crosses the play
    # beside it, without play the vanes follow the command (differ from the closed form by b/2 in the ramps)
    plain = _respond(backlash_servo_step, np.append(sp[:5], 0.0), np.array([0.5]), commands, 0.5)
    assert np.max(np.abs(plain - expected)) == pytest.approx(b / 2, abs=1e-12)


def test_dead_time_must_be_a_whole_number_of_control_steps():
    assert delay_steps(0.3, 0.02) == 15
    with pytest.raises(InputError, match=r"governor\.servo_dead_time_s = 0\.31 must be a whole multiple of the "
                                         r"control step 0\.02 s"):
        delay_steps(0.31, 0.02)


def test_every_servo_module_declares_its_governor_keys_and_the_governor_refuses_the_others():
    from simulate.components.control.governor import GovernorConfig

    owned = [k for name in SERVOS.names() for k in SERVOS.attribute(name, "GOVERNOR_KEYS", ())]
    assert sorted(owned) == sorted(GovernorConfig.servo_keys())  # each servo_* key belongs to exactly one servo
    base = dict(kp=2.0, ki=0.4, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0, servo_time_s=0.2,
                closing_time_s=12.0, opening_time_s=20.0)
    assert GovernorConfig(**base, servo_model="dead-time", servo_dead_time_s=0.2).servo_dead_time_s == 0.2
    with pytest.raises(InputError, match=r"governor\.servo_dead_time_s is a key of governor\.servo_model = "
                                         r"'dead-time'; with servo_model = 'backlash' it would be ignored"):
        GovernorConfig(**base, servo_model="backlash", servo_backlash=0.01, servo_dead_time_s=0.2)
    with pytest.raises(InputError, match=r"governor\.servo_model = \"backlash\" needs governor\.servo_backlash"):
        GovernorConfig(**base, servo_model="backlash")
    with pytest.raises(InputError, match=r"governor\.servo_model must be one of first-order, discrete, dead-time, "
                                         r"backlash, two-stage, rate-limit; got 'hydraulic'"):
        GovernorConfig(**base, servo_model="hydraulic")
    # the ramp limiter has no lag: servo_time_s would be ignored under it, and every other servo needs it
    lag_free = {k: v for k, v in base.items() if k != "servo_time_s"}
    assert GovernorConfig(**lag_free, servo_model="rate-limit").servo_time_s is None
    with pytest.raises(InputError, match=r"governor\.servo_time_s would be ignored: governor\.servo_model = "
                                         r"\"rate-limit\" has no lag; remove the key"):
        GovernorConfig(**base, servo_model="rate-limit")
    with pytest.raises(InputError, match=r"governor\.servo_model = \"first-order\" needs governor\.servo_time_s"):
        GovernorConfig(**lag_free)


def test_the_rate_limit_servo_is_a_ramp_without_lag():
    """Per step the stroke moves to the command, by at most dt / closing_time_s down and dt / opening_time_s up:
    a far command is approached on the exact ramp, a near one reached in one step; the first-order servo (T_y
    with dt / T_y = 0.1) on the same commands lags."""
    from simulate.components.control.rate_limit import rate_limit_parameters
    from simulate.components.control.governor import GovernorConfig

    gov = GovernorConfig(kp=2.0, ki=0.4, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
                         servo_model="rate-limit", closing_time_s=10.0, opening_time_s=20.0)
    sp = rate_limit_parameters(gov, 0.02)
    commands = np.concatenate([np.zeros(100), np.full(120, 0.7), np.full(5, 0.6985)])
    stroke = _respond(first_order_servo_step, sp, np.zeros(1), commands, 0.8)
    # closing from 0.8 at 0.002 a step for 100 steps, opening at 0.001 a step to the command 0.7 and holding it;
    # 1e-12: sums of up to 200 steps (rounding ~1e-16 each), far below the 1e-3 a wrong rate shows in one step
    expected = np.concatenate([0.8 - 0.002 * np.arange(1, 101), 0.6 + 0.001 * np.arange(1, 101), np.full(20, 0.7),
                               np.full(5, 0.6985)])
    np.testing.assert_allclose(stroke[:220], expected[:220], rtol=0, atol=1e-12)
    # a command 0.0015 below the stroke (inside one closing step of 0.002) is met in that step: no lag
    np.testing.assert_allclose(stroke[220:], 0.6985, rtol=0, atol=1e-12)
    # beside it, the first-order servo with the same rate limits is not this: near each command its lag (it closes
    # 1 - e^-0.1 of the gap a step) leaves it 0.0037 short where the ramp has arrived
    lagged = _respond(first_order_servo_step, FIRST_ORDER, np.zeros(1), commands, 0.8)
    assert np.max(np.abs(lagged - expected)) > 3e-3


# ---------------------------------------------------------------------------------------------------------------
# in the plant loop
# ---------------------------------------------------------------------------------------------------------------

#: the shipped unit on the ideal turbine and a rigid penstock at dt = 0.02 s: load rejection at t = 2 s with a stiff
#: governor (kp at its bound: the command drops to the lower stroke limit at once and stays there while the unit is
#: above speed), so the vanes close at the rate limit
REJECTION = {"turbine.characteristics": "ideal", "penstock.model": "rigid", "solver.dt_s": 0.02,
             "scenario.t_end_s": 14.0, "governor.kp": 1000.0}


def _run(overrides=None, jit=True):
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    return run_simulation(load_plant(PLANT_HLA339, {**REJECTION, **(overrides or {})}), jit=jit)


@pytest.mark.slow
def test_a_load_rejection_closes_at_the_rate_limit_exactly_and_a_dead_time_shifts_it():
    free = _run()
    dt, closing = 0.02, 12.0
    steps = np.diff(free.opening)
    # the governor sees the rejection in the speed at t = 2.02 s (one step after the event), so the vanes move from
    # the row of t = 2.04 s on
    moving = (free.time_s[1:] > 2.0 + 1.5 * dt) & (free.opening[1:] > 0.05)
    assert steps[np.flatnonzero(free.time_s[1:] > 2.0)[0]] == 0.0
    # at the limit (T_y (1 - e^-0.1) x stroke > dt / closing_time_s while the stroke is above 0.02): every step
    # closes by dt / closing_time_s to rounding (1e-12: the stroke is a sum of ~400 such steps)
    assert moving.sum() > 300
    np.testing.assert_allclose(steps[moving], -dt / closing, rtol=0, atol=1e-12)
    # beside it, the opening-time limit would be a different rate: 0.02 / 20 per step
    assert abs(steps[moving][0] + dt / 20.0) > 1e-4

    delayed = _run({"governor.servo_model": "dead-time", "governor.servo_dead_time_s": 0.3})
    n = 15
    assert delayed.summary()["servo_dead_time_steps"] == n
    # the commands stay at the lower stroke limit through the closure in both runs, so the vane stroke is the
    # delay-free one shifted by the dead time (1e-9: before the event the stiff governor sees rounding-level speed
    # deviations, ~1e-12 of stroke per unit of kp)
    window = free.time_s <= 10.0
    np.testing.assert_allclose(delayed.opening[n:][window[:-n]], free.opening[:-n][window[:-n]], rtol=0, atol=1e-9)
    assert np.max(np.abs(delayed.opening[window] - free.opening[window])) > 0.02  # not the same run


@pytest.mark.slow
def test_a_load_rejection_closes_on_the_rate_limit_servos_ramp_to_the_closed_end():
    """The ramp limiter without lag: from the row of t = 2.04 s (the governor sees the rejection at 2.02 s) the
    stroke falls by dt / closing_time_s every step while the command (the lower stroke limit) is more than one step
    below it, and the last step lands on 0: y(t) = max(0, y0 - (t - 2.02) / closing_time_s)."""
    from data_synthetic import PLANT_HLA339
    from simulate.loop.engine import run_simulation

    ramp = run_simulation(_load_without_lag(PLANT_HLA339, {**REJECTION, "governor.servo_model": "rate-limit"}))
    dt, closing = 0.02, 12.0
    y0 = ramp.opening[0]
    expected = np.where(ramp.time_s <= 2.02, y0, np.maximum(0.0, y0 - (ramp.time_s - 2.02) / closing))
    # 1e-12: the stroke is a sum of up to ~590 steps of dt / closing_time_s (rounding ~1e-16 each, measured 4e-17 per
    # step), far below the 1.7e-3 of one step early or late
    np.testing.assert_allclose(ramp.opening, expected, rtol=0, atol=1e-12)
    closed = np.flatnonzero(ramp.opening == 0.0)
    assert closed.size > 0 and ramp.time_s[closed[0]] == pytest.approx(2.02 + closing * y0, abs=dt)  # 13.76 s
    steps = np.diff(ramp.opening)[(ramp.time_s[1:] > 2.03) & (ramp.opening[1:] > 0.0)]
    assert steps.size > 500 and np.all(np.abs(steps + dt / closing) < 1e-15)
    # beside it, the first-order servo with the same rate limit leaves the ramp near the closed end (its lag): at
    # 13.76 s it is still 0.006 open
    lagged = _run()
    assert lagged.opening[closed[0]] > 5e-3


@pytest.mark.slow
def test_a_load_rejection_through_backlash_is_the_first_order_closure_plus_half_the_play():
    """Backlash b = 0.02 after the first-order servo: the command sits at the lower stroke limit through the closure
    (as in the runs above), so the piston follows the first-order run's stroke to the last bit and the vanes, dragged
    closed, stay b/2 above it: y = min(y0, y_first_order + b/2), ending b/2 short of the closed end."""
    free = _run()
    loose = _run({"governor.servo_model": "backlash", "governor.servo_backlash": 0.02})
    y0, half = free.opening[0], 0.01
    window = free.time_s <= 10.0
    expected = np.minimum(y0, free.opening + half)
    # 1e-9 as for the dead time above: before the event the stiff governor sees rounding-level speed deviations
    # (measured: equal to the last bit), against the 0.01 of the play
    np.testing.assert_allclose(loose.opening[window], expected[window], rtol=0, atol=1e-9)
    # the vanes wait while the piston takes up b/2 (0.01 at dt / closing_time_s a step: 6 steps, the sixth exactly
    # at the edge of the play)
    assert np.sum(loose.opening == y0) - np.sum(free.opening == y0) == 5
    assert loose.opening[-1] == pytest.approx(free.opening[-1] + half, abs=1e-9) and loose.opening[-1] > half
    # beside it, the vanes without play are off the closed form by the half play
    assert np.max(np.abs(free.opening[window] - expected[window])) == pytest.approx(half, abs=1e-12)


@pytest.mark.slow
def test_a_load_rejection_closes_along_the_two_stage_law_exactly():
    from simulate.components.control.governor import closure_law

    keys = {"governor.servo_model": "two-stage", "governor.servo_break_stroke": 0.3,
            "governor.servo_break_closing_time_s": 40.0, "scenario.t_end_s": 24.0}
    run = _run(keys)
    y0, start = run.opening[0], 2.0 + 0.02  # the vanes leave y0 in the step from t = 2.02 s (see the test above)
    times, strokes = closure_law(y0, start, 12.0, break_opening=0.3, break_time_s=40.0)
    # down to 0.01 (below it the servo's lag, not its rate limit, sets the speed: 0.02/40 < 0.01 (1 - e^-0.1));
    # 1e-12: the strokes are sums of up to ~1000 steps of dt/12 and dt/40
    window = run.opening > 0.01
    expected = np.interp(run.time_s, times, strokes)
    np.testing.assert_allclose(run.opening[window], expected[window], rtol=0, atol=1e-12)
    assert np.sum(window & (run.opening < 0.3)) > 500  # the second stage is run through (0.29 / (0.02/40) steps)
    # beside it, the one-stage law (the first-order servo) is not this run: it is at 0 where this one is at 0.2
    single = _run({"scenario.t_end_s": 24.0})
    assert np.max(np.abs(single.opening - run.opening)) > 0.1


@pytest.mark.slow
@pytest.mark.parametrize("model,keys", [("dead-time", {"governor.servo_dead_time_s": 0.3}),
                                         ("backlash", {"governor.servo_backlash": 0.02}),
                                         ("two-stage", {"governor.servo_break_stroke": 0.7,
                                                        "governor.servo_break_closing_time_s": 200.0})])
def test_each_servo_runs_in_the_compiled_loop_as_in_the_python_loop_and_changes_the_run(model, keys):
    # a load step down: the governor closes the vanes (a two-stage servo acts only in closing)
    overrides = {"governor.kp": 2.0, "scenario.kind": "load-step", "scenario.initial_power_mw": 180.0,
                 "scenario.load_step": -0.2, "scenario.t_end_s": 20.0, "governor.servo_model": model, **keys}
    compiled, python = _run(overrides), _run(overrides, jit=False)
    np.testing.assert_allclose(compiled.opening, python.opening, rtol=1e-12, atol=0)  # one source, two runners
    first = _run({k: v for k, v in overrides.items() if not k.startswith("governor.servo")})
    assert np.max(np.abs(compiled.opening - first.opening)) > 1e-4  # the servo acts
    assert compiled.summary()["servo_model"] == model


# ---------------------------------------------------------------------------------------------------------------
# every servo on every shipped example plant: it acts, or it is refused with its reason (never accepted and ignored)
# ---------------------------------------------------------------------------------------------------------------

#: the shipped example plants (every plant file of data_synthetic/: single unit, grid, surge tank, guarantee,
#: [[units]], double-regulated bulb)
SHIPPED = sorted(p.name for p in PLANT_HLA339.parent.glob("plant_*.toml"))


def _servo_keys(model: str, control_step_s: float) -> dict:
    """Keys of each servo that fit the plant's control step (sampling time and dead time: 10 control steps)."""
    return {"discrete": {"governor.servo_sample_time_s": 10 * control_step_s},
            "dead-time": {"governor.servo_dead_time_s": 10 * control_step_s},
            "backlash": {"governor.servo_backlash": 0.02},
            "rate-limit": {},
            "first-order": {}}[model]


def _two_stage_keys(largest_stroke: float) -> dict:
    """A second stage from just above the largest stroke of the run, closing a full stroke in 1000 s: any closing
    the governor asks for is held back (the first-order servo would follow it)."""
    return {"governor.servo_break_stroke": min(0.999, largest_stroke + 0.01),
            "governor.servo_break_closing_time_s": 1000.0}


def _load_without_lag(path, overrides):
    """The plant file with ``overrides`` and without ``governor.servo_time_s`` (a servo without lag refuses it)."""
    import tomllib

    from simulate.config import apply_overrides, plant_from_dict, read_plant_toml, split_study_sections

    raw = tomllib.loads(read_plant_toml(path)[1].decode())
    split_study_sections(raw)
    apply_overrides(raw, overrides)
    raw["governor"].pop("servo_time_s", None)
    return plant_from_dict(raw, base_dir=path.parent)


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_every_servo_acts_on_every_shipped_plant_or_is_refused_with_its_reason(name):
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    assert len(SHIPPED) == 10  # the list can fail: a new example plant joins it (or one is lost)
    path = PLANT_HLA339.parent / name
    short = {"scenario.t_end_s": 4.0, "scenario.event_time_s": 1.0}
    if load_plant(path).scenario.kind == "load-step":  # a load step down: the vanes close (the two-stage servo
        short["scenario.load_step"] = -0.1            # acts in closing only)
    if load_plant(path).scenario.kind == "start-up" or load_plant(path).governor.opening_reference is not None:
        short["scenario.t_end_s"] = 20.0  # past the start-up's first closing / the closure's end at the rate limit
    default = run_simulation(load_plant(path, short))
    governor = load_plant(path).governor
    # holds the initial stroke (the pump-turbine's runaway and pump trip, vanes blocked); the pump trip with closure
    # moves the vanes to its opening_reference
    blocked = governor.mode == "opening" and governor.opening_reference is None
    control_step_s = default.summary()["dt_s"] / default.summary()["substeps"]
    for model in SERVOS.names()[1:]:
        keys = _two_stage_keys(default.opening.max()) if model == "two-stage" else _servo_keys(model, control_step_s)
        plant = _load_without_lag(path, {**short, "governor.servo_model": model, **keys}) \
            if not SERVOS.attribute(model, "LAG", True) else load_plant(path, {**short, "governor.servo_model": model,
                                                                               **keys})
        result = run_simulation(plant)
        moved = np.max(np.abs(result.opening - default.opening))
        if blocked:  # opening control commands the initial stroke, which the vanes already hold: no servo
            assert moved == 0.0 and np.all(result.opening == result.opening[0]), (name, model, moved)  # moves it
            continue
        # the governor acts on the event within 4 s: a servo that changes nothing would leave the opening equal to
        # the default servo's run to the last bit; each of these moves it by more than 1e-6 of the stroke
        assert moved > 1e-6, (name, model, moved)
        assert result.summary()["servo_model"].startswith(model)
    # the default sampling time (0.2 s) may not fit the plant's step: then the run is refused, naming the key (on a
    # plant with [[units]] after the unit's name)
    try:
        run_simulation(load_plant(path, {**short, "governor.servo_model": "discrete"}))
    except InputError as exc:
        assert "governor.servo_sample_time_s = 0.2 must be a whole multiple of the time step" in str(exc), str(exc)


#: A servo written outside the package as a user would: one module (the first-order servo with twice the plant's
#: time constant) and one registry line; nothing else of hillsim changes.
USER_SERVO = '''
import numba
from dataclasses import replace

from simulate.components.control.servo import Servo, first_order_parameters, servo_step
import numpy as np


@numba.njit(cache=False)
def step(sp, ss, command, stroke, dt_s):
    return servo_step(sp, command, stroke)


def build(governor, initial_stroke, dt_s):
    slow = replace(governor, servo_time_s=2.0 * governor.servo_time_s)
    return Servo(step, first_order_parameters(slow, dt_s), np.zeros(1), summary={"servo_model": "user-slow"})


def time_scales(plant, schedules):
    from simulate.components.timescale import TimeScale

    return [TimeScale("user servo 2 T_y", 2.0 * plant.governor.servo_time_s)]
'''


@pytest.mark.slow
def test_a_servo_is_one_module_and_one_registry_line(tmp_path, monkeypatch):
    import sys

    (tmp_path / "user_slow_servo.py").write_text(USER_SERVO, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(SERVOS._entries, "user-slow", "user_slow_servo:build")
    try:
        overrides = {"scenario.kind": "load-step", "scenario.initial_power_mw": 180.0, "scenario.t_end_s": 10.0,
                     "governor.kp": 2.0}
        user = _run({**overrides, "governor.servo_model": "user-slow"})
        assert user.summary()["servo_model"] == "user-slow"
        # the same as the shipped first-order servo with T_y doubled, to the last bit (same equation, same numbers)
        doubled = _run({**overrides, "governor.servo_time_s": 0.4})
        np.testing.assert_array_equal(user.opening, doubled.opening)
        # beside it, the plant's own T_y gives another run
        assert np.max(np.abs(_run(overrides).opening - user.opening)) > 1e-5
    finally:
        sys.modules.pop("user_slow_servo", None)
