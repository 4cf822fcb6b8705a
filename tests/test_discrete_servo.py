"""Paper 000 eq. (37) discrete servo: printed coefficients, scipy cross-check, sampling, garbage input."""

import numpy as np
import pytest
import scipy.signal

from hillchart.errors import InputError
from simulate.discrete_servo import (DiscreteServoConfig, check_servo_step, discrete_servo_parameters,
                                     discrete_servo_step, initial_servo_state)


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
