"""Paper 000 eq. (37) discrete servo: printed coefficients, scipy cross-check, sampling, garbage input."""

import numpy as np
import pytest
import scipy.signal

from hillchart.errors import InputError
from simulate.components.control.discrete_servo import (DiscreteServoConfig, check_servo_step,
                                                        discrete_servo_parameters, discrete_servo_step,
                                                        initial_servo_state, servo_config)


def _run(config, commands, dt, y0=0.0, jit=True):
    step = discrete_servo_step if jit else discrete_servo_step.py_func
    p, s = discrete_servo_parameters(config), initial_servo_state(y0)
    return np.array([step(p, s, c, dt) for c in commands])


def test_printed_servo_is_unit_gain_stable_and_matches_scipy_dlti():
    cfg = DiscreteServoConfig()
    num, den = cfg.transfer_function()
    poles = np.roots(den)
    np.testing.assert_allclose(sorted(poles, key=np.imag), [0.5 - 0.5j, 0.5 + 0.5j], atol=1e-15)
    assert np.polyval(num, 1.0) / np.polyval(den, 1.0) == pytest.approx(1.0, abs=1e-15)  # DC gain
    n = 40
    ours = _run(cfg, np.full(n, 0.01), 0.2)  # one call per sample
    _, (ref,) = scipy.signal.dstep(scipy.signal.dlti(num, den, dt=0.2), n=n)
    np.testing.assert_allclose(ours, 0.01 * ref.ravel(), atol=1e-15)  # same recursion: exact
    # printed values of the recursion: 0.5, 1.0, 1.25, 1.25, 1.125 of the step (overshoot 25 %)
    np.testing.assert_allclose(ours[:5] / 0.01, [0.5, 1.0, 1.25, 1.25, 1.125], atol=1e-12)
    assert ours[-1] == pytest.approx(0.01, rel=1e-6)


def test_servo_samples_every_tau_and_holds_in_between():
    cfg = DiscreteServoConfig()
    fine = _run(cfg, np.full(200, 0.6), 0.02, y0=0.5)  # 10 loop steps per sample
    coarse = _run(cfg, np.full(20, 0.6), 0.2, y0=0.5)
    np.testing.assert_array_equal(fine.reshape(20, 10), np.repeat(coarse[:, None], 10, axis=1))
    assert fine[0] == pytest.approx(0.55)  # absolute strokes: 0.5 + 0.5 * (0.6 - 0.5) at the first sample
    np.testing.assert_array_equal(_run(cfg, np.full(50, 0.6), 0.02, y0=0.5, jit=False), fine[:50])


def test_stroke_limits_clip_the_output():
    out = _run(DiscreteServoConfig(stroke_max=1.0), np.full(10, 1.2), 0.2, y0=0.9)
    assert out.max() == 1.0


@pytest.mark.parametrize("kw, match", [
    ({"b0": 0.4}, r"servo: DC gain b0 / \(1 - a1 - a2\) must be 1"),
    ({"a1": -1.0}, r"servo: DC gain .* got 0.5 / 2.5"),  # the "+ z^-1" reading: DC gain 0.2
    ({"a1": 2.5, "a2": -2.0, "b0": 0.5}, r"servo: poles of 1 - a1 z\^-1 - a2 z\^-2 must be inside the unit circle"),
    ({"sample_time_s": 0.0}, r"servo.sample_time_s must be in \(0.0, 10.0\]"),
    ({"b0": "half"}, r"servo.b0 must be a number"),
    ({"stroke_min": 0.8, "stroke_max": 0.5}, r"servo.stroke_min must be < servo.stroke_max"),
])
def test_bad_servo_configs_are_rejected(kw, match):
    with pytest.raises(InputError, match=match):
        DiscreteServoConfig(**kw)


def test_loop_step_must_divide_the_servo_sampling():
    assert check_servo_step(DiscreteServoConfig(), 0.02) == 10
    with pytest.raises(InputError, match="must be a whole multiple of the time step 0.03"):
        check_servo_step(DiscreteServoConfig(), 0.03)


# ---------------------------------------------------------------------------------------------------------------
# the servo option of the governor in the plant loop (governor.servo_model = "discrete")
# ---------------------------------------------------------------------------------------------------------------

LOOP = {"turbine.characteristics": "ideal", "penstock.model": "rigid", "solver.dt_s": 0.02,
        "scenario.kind": "load-step", "scenario.initial_power_mw": 180.0, "scenario.event_time_s": 1.0,
        "scenario.t_end_s": 60.0}


def _plant(**overrides):
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant

    return load_plant(PLANT_HLA339, {**LOOP, **overrides})


@pytest.mark.slow
def test_discrete_servo_option_samples_every_tau_and_settles_where_the_first_order_servo_does():
    from simulate.loop.engine import run_simulation

    first = run_simulation(_plant())
    plant = _plant(**{"governor.servo_model": "discrete"})
    # the printed eq. (37) at 0.2 s by default, with the governor's rate limits
    assert servo_config(plant.governor) == DiscreteServoConfig(closing_time_s=12.0, opening_time_s=20.0)
    assert plant.with_overrides({"scenario.t_end_s": 30.0}).governor == plant.governor  # round trip keeps the keys
    disc = run_simulation(plant)
    assert disc.summary()["servo_model"].startswith("discrete")
    # the stroke moves only at the servo's sampling instants: every 10th step (tau 0.2 s / dt 0.02 s); row k + 1
    # holds the stroke the step from t_k commands, so the rows are 1 mod 10 (rounding-level moves, ~1e-15, allowed
    # elsewhere: the recursion a1 y0 + a2 y0 + b0 y0 = y0 is exact only up to rounding)
    moved = np.flatnonzero(np.abs(np.diff(disc.opening)) > 1e-12) + 1
    assert moved.size > 20 and np.all(moved % 10 == 1)
    # same governor, same load: the same final stroke (integral action); the servo's dynamics differ on the way
    assert disc.opening[-1] == pytest.approx(first.opening[-1], abs=1e-6)
    assert np.max(np.abs(disc.opening - first.opening)) > 1e-3
    slow = run_simulation(plant, jit=False)  # compiled loop = Python loop with the discrete servo
    np.testing.assert_allclose(slow.opening, disc.opening, rtol=1e-12, atol=0)


@pytest.mark.parametrize("overrides,match", [
    ({"governor.servo_model": "second-order"}, r"governor\.servo_model must be one of first-order, discrete, "
                                               r"dead-time, backlash, two-stage, rate-limit; "
                                               r"got 'second-order'"),
    ({"governor.servo_b0": 0.5}, r"governor\.servo_b0 is a key of governor\.servo_model = 'discrete'; with "
                                 r"servo_model = 'first-order' it would be ignored"),
    ({"governor.servo_model": "discrete", "governor.servo_b0": 0.4},
     r"governor \(servo_model = \"discrete\", eq\. \(37\)\): DC gain b0 / \(1 - a1 - a2\) must be 1"),
    ({"governor.servo_model": "discrete", "governor.servo_a2": -1.0, "governor.servo_b0": 1.0},
     r"poles of 1 - a1 z\^-1 - a2 z\^-2 must be inside the unit circle"),
    ({"governor.servo_model": "discrete", "governor.servo_sample_time_s": -0.2},
     r"governor\.servo_sample_time_s must be in \(0\.0, 10\.0\], got -0\.2"),
    ({"governor.servo_model": "discrete", "governor.servo_a1": "one"},
     r"governor\.servo_a1 must be a number in \[-10\.0, 10\.0\], got 'one'"),
])
def test_bad_discrete_servo_keys_are_named(overrides, match):
    with pytest.raises(InputError, match=match):
        _plant(**overrides)


def test_servo_sampling_must_be_a_multiple_of_the_time_step_in_the_loop():
    from simulate.loop.engine import run_simulation

    with pytest.raises(InputError, match=r"governor\.servo_sample_time_s = 0\.21 must be a whole multiple of the time "
                                         r"step 0\.02 s .*set solver\.dt_s"):
        run_simulation(_plant(**{"governor.servo_model": "discrete", "governor.servo_sample_time_s": 0.21}))


@pytest.mark.slow
def test_the_discrete_servo_drives_the_vanes_of_a_double_regulated_unit():
    """The bulb plant's governor drives its vanes through the servo governor.servo_model names, as the Francis
    plant's: the key ran there once and changed nothing (the vane opening equalled the default servo's run
    exactly), then was refused; now the eq. (37) servo moves the vanes only at its sampling instants."""
    from data_synthetic import PLANT_BULB
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    short = {"scenario.t_end_s": 4.0}
    first = run_simulation(load_plant(PLANT_BULB, short))
    plant = load_plant(PLANT_BULB, {**short, "governor.servo_model": "discrete"})
    disc = run_simulation(plant)
    assert disc.success and disc.summary()["servo_model"].startswith("discrete")
    steps = int(round(0.2 / disc.summary()["dt_s"] * disc.summary()["substeps"]))
    moved = np.flatnonzero(np.abs(np.diff(disc.opening)) > 1e-12) + 1
    # the stroke moves only at the servo's sampling instants (every `steps` loop steps; rows as in the test above)
    assert moved.size > 3 and np.all(moved % (steps // disc.summary()["substeps"]) == 1)
    assert np.max(np.abs(disc.opening - first.opening)) > 1e-3  # the key acts: not the first-order run


def test_a_servo_is_refused_where_a_prescribed_law_drives_the_vanes():
    """closure-law and opening-steps prescribe the vane stroke: no governor and no servo is in the loop, so a servo
    other than the default would be accepted and ignored; it is refused, naming the key and why (single unit and
    double-regulated unit; the run stops before anything is compiled)."""
    from data_synthetic import PLANT_BULB, PLANT_HLA339
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    for path in (PLANT_HLA339, PLANT_BULB):
        for kind, keys in (("closure-law", {"scenario.closing_time_s": 10.0}), ("opening-steps", {})):
            plant = load_plant(path, {"governor.servo_model": "discrete", "scenario.kind": kind,
                                      "scenario.t_end_s": 3.0, **keys})
            with pytest.raises(InputError, match=rf"governor\.servo_model = 'discrete' would be ignored: the "
                                                 rf"prescribed law of scenario\.kind = '{kind}' drives the guide "
                                                 rf"vanes"):
                run_simulation(plant)
