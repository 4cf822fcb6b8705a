"""Penstock models: the paper's z-domain example, Tustin cross-checks, MOC steady state, the per-step relation."""

import math

import numpy as np
import pytest
from scipy import signal

from simulate.config import PenstockConfig, PenstockSegment
from simulate.components.hydraulic.penstock import (build_moc_grid, iir_coefficients, iir_step, iir_turbine_relation,
                               moc_steady_state,
                               moc_step, moc_turbine_relation, zdomain_coefficients, zdomain_original)


def test_zdomain_paper_example_before_resampling_eq21():
    # L = 100 m, a = 1000 m/s -> T_so = 0.1 s; Tw = 2 s; F = 0.01: (-16.67 z^2 + 16.67) / (z^2 + 0.6667)
    num, den = zdomain_original(100.0 / 1000.0, 2.0, 0.01)
    assert np.round(num, 2).tolist() == [-16.67, 0.0, 16.67]  # printed digits of eq. (21)
    assert np.round(den, 4).tolist() == [1.0, 0.0, 0.6667]


def test_zdomain_paper_example_after_resampling_eq22():
    # T_sn = 0.01 s: (-3.81 z^2 + 3.81) / (z^2 - 1.886 z + 0.9238)
    a_c, b_c, d_c, e_c = zdomain_coefficients(0.1, 2.0, 0.01, 0.01)
    assert (round(a_c, 2), round(b_c, 2), round(d_c, 3), round(e_c, 4)) == (-3.81, 3.81, -1.886, 0.9238)


@pytest.mark.parametrize("feedback", [0.0, 0.01, 0.2])
def test_zdomain_equals_tustin_of_its_continuous_equivalent(feedback):
    # Mapping eq. (17) back with eq. (13) gives G(s) = -Tw s / (1 + F Tw s + (T_so/2)^2 s^2); eqs. (19)-(20) must be
    # scipy's bilinear transform of it at the new step (checks the algebra of eq. (20) independently).
    t_so, tw, dt = 0.1, 2.0, 0.01
    num, den, _ = signal.cont2discrete(([-tw, 0.0], [(t_so / 2) ** 2, feedback * tw, 1.0]), dt, method="bilinear")
    num = np.ravel(num) / den[0]
    den = np.asarray(den) / den[0]
    a_c, b_c, d_c, e_c = zdomain_coefficients(t_so, tw, dt, feedback)
    np.testing.assert_allclose([a_c, 0.0, b_c], num, atol=1e-12)  # rounding of a few products
    np.testing.assert_allclose([1.0, d_c, e_c], den, atol=1e-12)


def test_resampling_to_the_same_period_changes_nothing():
    # T_sn = T_so: eq. (16) is the identity, so (19) must equal (17)
    a_c, b_c, d_c, e_c = zdomain_coefficients(0.1, 2.0, 0.1, 0.01)
    num, den = zdomain_original(0.1, 2.0, 0.01)
    np.testing.assert_allclose([a_c, b_c, d_c, e_c], [num[0], num[2], den[1], den[2]], atol=1e-12)


def test_lumped_resonance_is_the_first_pipe_mode():
    # alpha = 4/pi^2: the discrete poles sit at the Tustin image of s = +-j pi a / (2 L)
    te, tw, dt = 0.4, 1.5, 0.005
    coef = iir_coefficients("lumped", water_time_s=tw, travel_time_s=te, step_s=dt)
    poles = np.roots([1.0, coef[3], coef[4]])
    assert np.allclose(np.abs(poles), 1.0, atol=1e-12)  # undamped
    omega_d = np.abs(np.angle(poles[0])) / dt
    omega_expected = 2 / dt * math.atan(math.pi / (2 * te) * dt / 2)  # Tustin frequency warping
    assert omega_d == pytest.approx(omega_expected, rel=1e-9)
    # Tustin identity: G_d(exp(j w dt)) = G_c(j (2/dt) tan(w dt / 2)) with G_c = -Tw s / (1 + alpha Te^2 s^2)
    alpha = 4 / math.pi ** 2
    for w in (0.1, 1.0, 5.0, 50.0):
        _, g_d = signal.freqz([coef[0], coef[1], coef[2]], [1.0, coef[3], coef[4]], worN=[w * dt])
        s_c = 1j * 2 / dt * math.tan(w * dt / 2)
        assert g_d[0] == pytest.approx(-tw * s_c / (1 + alpha * te ** 2 * s_c ** 2), rel=1e-9)


def test_rigid_is_backward_euler_of_tw_dq_dt():
    coef = iir_coefficients("rigid", water_time_s=2.0, travel_time_s=0.3, step_s=0.01)
    hist = np.array([0.0, 0.0, 0.0, 0.0, 10.0])
    iir_step(coef, hist, 10.5, 10.0, 5.0)  # q goes 0 -> 0.1 in one step: h = -Tw * 0.1 / 0.01 = -20
    assert hist[2] == pytest.approx(-20.0, rel=1e-14)
    iir_step(coef, hist, 10.5, 10.0, 5.0)  # q constant: h = 0 at once (no trapezoidal ringing)
    assert hist[2] == 0.0


def test_iir_relation_is_linear_with_negative_slope_and_exact_at_steady_state():
    coef = iir_coefficients("zdomain", water_time_s=1.5, travel_time_s=0.44, step_s=0.02)
    hist = np.array([0.0, 0.0, 0.0, 0.0, 140.0])
    c_l, k = iir_turbine_relation(coef, hist, 180.0, 1e-4, 176.0, 142.5, 140.0)
    assert k < 0
    assert c_l + k * 140.0 == pytest.approx(180.0 - 1e-4 * 140.0 ** 2, rel=1e-14)


def _pipe(reaches=4, friction=0.02):
    return PenstockConfig(model="moc", static_head_m=100.0, reaches=reaches, segments=(
        PenstockSegment(length_m=300.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=friction),
        PenstockSegment(length_m=200.0, diameter_m=1.6, wave_speed_m_s=1000.0, darcy_friction=friction)))


def test_moc_steady_state_is_a_fixed_point_with_total_friction_loss():
    pen = _pipe()
    grid = build_moc_grid(pen, pen.moc_time_step_s)
    heads, flows = moc_steady_state(grid, 100.0, 8.0)
    # total loss equals K Q^2 of the config (same sum of f L / (2 g D A^2))
    assert 100.0 - heads[-1] == pytest.approx(pen.friction_coefficient_s2_m5 * 64.0, rel=1e-12)
    new_h, new_q = heads.copy(), flows.copy()
    c_l, k = moc_turbine_relation(heads, flows, grid.impedance_s_m2, grid.friction_s2_m5)
    assert c_l + k * 8.0 == pytest.approx(heads[-1], rel=1e-14)
    moc_step(heads, flows, grid.impedance_s_m2, grid.friction_s2_m5, 100.0, heads[-1], 8.0, new_h, new_q)
    np.testing.assert_allclose(new_h, heads, rtol=1e-14)
    np.testing.assert_allclose(new_q, flows, rtol=1e-13)


def test_moc_junction_transmits_and_reflects_like_joukowsky():
    # A pressure step travelling into a smaller pipe: transmitted fraction 2 B2 / (B1 + B2) (frictionless)
    pen = _pipe(reaches=4, friction=0.0)
    grid = build_moc_grid(pen, pen.moc_time_step_s)
    heads, flows = moc_steady_state(grid, 100.0, 0.0)
    n1 = grid.reaches_per_segment[0]
    heads[: n1 // 2 + 1] += 1.0  # not physical, but a clean wave: raise head and matching flow on part of pipe 1
    flows[: n1 // 2 + 1] += 1.0 / grid.impedance_s_m2[0]  # C+ wave moving downstream: dH = B dQ
    b1, b2 = grid.impedance_s_m2[0], grid.impedance_s_m2[-1]
    new_h, new_q = heads.copy(), flows.copy()
    peak_downstream = 0.0
    for _ in range(n1 + 2):
        c_l, k = moc_turbine_relation(heads, flows, grid.impedance_s_m2, grid.friction_s2_m5)
        moc_step(heads, flows, grid.impedance_s_m2, grid.friction_s2_m5, 100.0, 100.0, 0.0, new_h, new_q)
        heads, new_h = new_h, heads
        flows, new_q = new_q, flows
        peak_downstream = max(peak_downstream, heads[n1 + 2] - 100.0)
    assert peak_downstream == pytest.approx(2 * b2 / (b1 + b2), rel=1e-12)
