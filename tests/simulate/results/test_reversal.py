"""The four-quadrant figures of a unit's series (simulate.results.reversal) on series whose answers are known by
hand: a turbine running away into reverse flow, a pump tripping into reverse rotation, a governor closing the vanes
(no runaway), a run that never reverses."""

import numpy as np
import pytest

from simulate.results.reversal import PEAK_PROMINENCE, reversal_figures

T = np.linspace(0.0, 10.0, 1001)  # 0.01 s


def test_a_turbine_running_away_into_reverse_flow():
    """n = n_r (1 + 0.5 sin(pi t / 8)) peaks at t = 4 s; Q = 10 cos(pi t / 6) crosses zero at t = 3 s (a sample:
    the interpolation is exact to round-off, 1e-9 s) and reaches -10 at t = 6 s; the speed never turns."""
    n = 500.0 * (1 + 0.5 * np.sin(np.pi * np.minimum(T, 4.0) / 8.0)) - 10.0 * np.maximum(T - 4.0, 0.0)
    q = 10.0 * np.cos(np.pi * T / 6.0)
    f = reversal_figures(T, n, q, np.full(T.size, 0.7), 500.0)
    assert f["max_reverse_speed_rpm"] == 0.0 and f["max_reverse_speed_pct"] == 0.0
    assert f["max_reverse_flow_m3_s"] == pytest.approx(10.0, abs=1e-9)
    assert f["t_flow_reversal_s"] == pytest.approx(3.0, abs=1e-9)
    assert f["t_runaway_s"] == pytest.approx(4.0, abs=1e-9)
    # the vanes closing (a governor): the same peak is no runaway
    closing = reversal_figures(T, n, q, 0.7 - 0.01 * T, 500.0)
    assert closing["t_runaway_s"] is None and closing["t_flow_reversal_s"] == f["t_flow_reversal_s"]


def test_a_pump_tripping_into_reverse_rotation():
    """Pump mode is n < 0, Q < 0: after the trip Q = -5 + 2.5 (t - 0.005) turns positive at t = 2.005 s, between
    two samples (linear: the interpolation is exact to round-off), up to 19.9875 m^3/s at 10 s; the speed
    n = -500 + 800 sin^2(pi t / 16) passes zero into the turbine direction, up to +300 r/min = 60 % of 500 r/min,
    its reverse-runaway peak at t = 8 s (after it the speed is held: a plateau)."""
    q = -5.0 + 2.5 * (T - 0.005)
    n = -500.0 + 800.0 * np.sin(np.pi * np.minimum(T, 8.0) / 16.0) ** 2
    f = reversal_figures(T, n, q, np.full(T.size, 0.5), 500.0)
    assert f["max_reverse_speed_rpm"] == pytest.approx(300.0, abs=1e-9)
    assert f["max_reverse_speed_pct"] == pytest.approx(60.0, abs=1e-9)
    assert f["max_reverse_flow_m3_s"] == pytest.approx(19.9875, abs=1e-9)
    assert f["t_flow_reversal_s"] == pytest.approx(2.005, abs=1e-9)
    assert f["t_runaway_s"] == pytest.approx(8.0, abs=1e-9)


def test_a_run_that_never_reverses_and_a_wiggle_that_is_no_peak():
    """A steady unit whose speed wiggles by round-off (1e-9 of n_r, far below the prominence) has no runaway, no
    reversal, and zero reverse speed and flow."""
    n = 500.0 + 5e-7 * np.sin(40 * T)
    f = reversal_figures(T, n, np.full(T.size, 10.0), np.full(T.size, 0.7), 500.0)
    assert f == {"max_reverse_speed_rpm": 0.0, "max_reverse_speed_pct": 0.0, "max_reverse_flow_m3_s": 0.0,
                 "t_flow_reversal_s": None, "t_runaway_s": None}
    # the same wiggle a hundredth of the rated speed high is a peak
    big = 500.0 + 1.01 * PEAK_PROMINENCE * 500.0 * np.sin(np.pi * T / 4.0) ** 2
    assert reversal_figures(T, big, np.full(T.size, 10.0), np.full(T.size, 0.7), 500.0)["t_runaway_s"] \
        == pytest.approx(2.0, abs=1e-9)
