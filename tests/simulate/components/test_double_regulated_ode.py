"""A double-regulated unit on a rigid water column with an ideal (linear) turbine against a direct ODE solution
(scipy's solve_ivp): the loop's turbine boundary, rigid intake, rigid draft tube, blade servo and rotor together."""

import math

import numba
import numpy as np
import pytest

from data_synthetic import PLANT_BULB
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

RHO_G = 1000.0 * 9.81
Q11_MAX, A_MAX, BLADE_GAIN, EFFICIENCY = 2.0, 43.0, 0.02, 0.9  # Q11 at full vane and phi = 0; per deg of blade


@numba.njit(cache=True)
def linear_three_input_kernel(params, n11, controls):
    """Q11 = Q11_max a / a_max (1 + c phi), constant efficiency: (q11, dq11/dn11, m11, dm11/dn11)."""
    coef, scal = params
    opening = controls[0] + scal[0]
    blade = scal[1] + controls[1] * scal[2]
    q = coef[0] * opening / coef[1] * (1.0 + coef[2] * blade)
    m = coef[3] * q / n11
    return q, 0.0, m, -m / n11


class LinearDoubleRegulated:
    """An ideal double-regulated turbine (three inputs), linear in the vane opening and the blade angle."""

    torque_const = RHO_G * EFFICIENCY * 60.0 / (2.0 * math.pi)

    def q11(self, n11, opening, blade_angle):
        return Q11_MAX * np.asarray(opening) / A_MAX * (1.0 + BLADE_GAIN * np.asarray(blade_angle)) + 0 * n11

    def m11(self, n11, opening, blade_angle):
        return self.torque_const * self.q11(n11, opening, blade_angle) / n11

    def efficiency(self, n11, opening, blade_angle):
        return np.full(np.broadcast(n11, opening, blade_angle).shape, EFFICIENCY)

    def numba_three_input_kernel(self):
        return linear_three_input_kernel, (np.array([Q11_MAX, A_MAX, BLADE_GAIN, self.torque_const]),)


def _plant(dt_s):
    return load_plant(PLANT_BULB, {
        "penstock.model": "rigid", "draft_tube.model": "rigid", "solver.dt_s": dt_s,
        "combinator.relation": "table", "combinator.opening_at_zero_stroke": 0.0,
        "combinator.table_openings": [0.0, 43.0], "combinator.table_heads_m": [5.0, 20.0],
        "combinator.table_angles_deg": [[0.0, 0.0], [0.0, 0.0]],
        "blade_servo.mode": "law", "blade_servo.law_start_s": 1.0, "blade_servo.law_target_deg": -10.0,
        "generator.self_regulation": 0.0, "scenario.kind": "closure-law", "scenario.closing_time_s": 12.0,
        "scenario.t_end_s": 4.0})


def test_rigid_double_regulated_unit_matches_a_direct_ode_solution():
    from scipy.integrate import solve_ivp

    dt = 0.002
    plant = _plant(dt)
    r = run_simulation(plant, LinearDoubleRegulated())
    assert r.meta["compiled"] and r.meta["dt_s"] == pytest.approx(dt)
    t, d = plant.turbine, plant.turbine.runner_diameter_m
    inertance = plant.penstock.inertance_s2_m2 + plant.draft_tube.mirrored().inertance_s2_m2
    friction = plant.penstock.friction_coefficient_s2_m5 + plant.draft_tube.friction_coefficient_s2_m5
    servo = plant.blade_servo
    y0 = r.opening[0]
    m_r, n_r, ta = t.rated_torque_nm, t.rated_speed_rpm, plant.generator.inertia_time_s
    load0 = r.torque_nm[0] / m_r  # the steady load equals the turbine torque
    event, closing = plant.scenario.event_time_s, plant.scenario.closing_time_s
    span = servo.angle_max_deg - servo.angle_min_deg

    def stroke(time):  # the prescribed closure from the event on
        return max(y0 - max(time - event, 0.0) / closing, 0.0)

    def rhs(time, z):
        flow, speed, blade = z
        q11 = Q11_MAX * stroke(time) * t.opening_max / A_MAX * (1.0 + BLADE_GAIN * blade)
        head = (flow / (d * d * q11)) ** 2  # Q = Q11 D^2 sqrt(H)
        torque = LinearDoubleRegulated.torque_const * q11 * d ** 3 * head / (speed * d / math.sqrt(head))
        load = load0 if time < event else 0.0
        command = 0.0 if time < servo.law_start_s else -10.0
        rate = (command - blade) / servo.servo_time_s  # first-order servo, rate limited (deg/s)
        rate = min(max(rate, -span / servo.closing_time_s), span / servo.opening_time_s)
        return [(plant.penstock.static_head_m - friction * flow * abs(flow) - head) / inertance,
                n_r / ta * (torque / m_r - load), rate]

    sol = solve_ivp(rhs, (0.0, r.time_s[-1]), [r.flow_m3_s[0], r.speed_rpm[0], 0.0], method="LSODA",
                    t_eval=r.time_s, rtol=1e-10, atol=1e-10, max_step=0.01)
    assert sol.success
    flow, speed, blade = sol.y
    # first-order schemes (backward Euler column, explicit Euler rotor, torque held over the step) at dt = 2 ms:
    # measured 0.011 r/min of an 80 r/min rise, 0.005 m3/s of 53, 0.002 deg; bounds about 3x that
    np.testing.assert_allclose(r.speed_rpm, speed, atol=0.03)
    np.testing.assert_allclose(r.flow_m3_s, flow, atol=0.02)
    np.testing.assert_allclose(r.signals["blade_angle_deg"], blade, atol=0.006)
    assert np.ptp(speed) > 10.0 and np.ptp(blade) > 2.0  # the run goes somewhere: the checks can fail
    # the draft tube's head: H_out = K_d Q|Q| + I_d dQ/dt, dQ/dt from the ODE's flow
    dflow = np.gradient(flow, sol.t)
    h_out = (plant.draft_tube.friction_coefficient_s2_m5 * flow * np.abs(flow)
             + plant.draft_tube.mirrored().inertance_s2_m2 * dflow)
    inside = (r.time_s > 0.1) & (np.abs(r.time_s - plant.scenario.event_time_s) > 0.05)  # away from the kink
    np.testing.assert_allclose(r.signals["draft_tube_head_m"][inside], h_out[inside], atol=0.003)  # measured 9e-4 m
    # and with the step halved the simulator moves towards the ODE (first order: the error about halves)
    fine = run_simulation(_plant(dt / 2), LinearDoubleRegulated())
    err = np.max(np.abs(r.speed_rpm - speed))
    err_fine = np.max(np.abs(fine.speed_rpm[::2] - speed[: fine.speed_rpm[::2].size]))
    assert err_fine < 0.7 * err


def test_the_ode_check_sees_a_wrong_blade_gain():
    """The same comparison fails when the simulated turbine's blade dependence differs (a check that can fail)."""
    plant = _plant(0.002)
    right = run_simulation(plant, LinearDoubleRegulated())

    class Wrong(LinearDoubleRegulated):
        def numba_three_input_kernel(self):
            return linear_three_input_kernel, (np.array([Q11_MAX, A_MAX, 2 * BLADE_GAIN, self.torque_const]),)

    wrong = run_simulation(plant, Wrong())
    assert np.max(np.abs(wrong.speed_rpm - right.speed_rpm)) > 0.5  # 15x the bound of the ODE comparison
