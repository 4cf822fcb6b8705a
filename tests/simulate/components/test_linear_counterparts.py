"""A component's linear counterpart (its declared :class:`simulate.components.contract.LinearBlock`) agrees with the
nonlinear component it stands for: the compiled rotor and the rigid penstock, stepped on their own at a part-load
operating point, against the step and ramp responses of their blocks in paper 000's increments (x = dn/n0,
h = dH/H0, q = dQ/Q0, torques over M0). Beside each, the failing case: the block's numbers taken at the rated point
instead of the operating point miss by far more than the tolerance."""

import math

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from simulate.components.registry import PENSTOCKS, SHAFTS, shaft_section
from simulate.config import load_plant
from simulate.loop.prepare import initial_state, plant_schedules

#: Part load (180 of 225 MW), so that the operating point's M0, Q0, H0, n0 differ from the rated ones.
PART_LOAD = {"turbine.characteristics": "ideal", "penstock.model": "rigid", "scenario.kind": "load-step",
             "scenario.initial_power_mw": 180.0, "scenario.load_step": 0.05, "scenario.event_time_s": 1000.0,
             "scenario.t_end_s": 2000.0}


@pytest.fixture(scope="module")
def operating_point():
    plant = load_plant(PLANT_HLA339, PART_LOAD)
    steady = initial_state(plant)
    return plant, steady, plant_schedules(plant, steady)


def _rotor_response(plant, steady, schedules, torque_step, dt_s, t_end_s):
    """The swing rotor (the run's compiled part, its Python function) under the turbine torque M0 (1 + step) from
    t = 0, the load held at its initial value: the relative speed deviation x at each step."""
    rotor = SHAFTS.builder(shaft_section(plant)[0])(plant, steady, dt_s, schedules)
    step = rotor.functions["step"].py_func
    torque = steady.torque_nm * (1.0 + torque_step)
    n = int(round(t_end_s / dt_s))
    speeds = np.array([step(rotor.params, rotor.state, torque, k * dt_s, dt_s) for k in range(n)])
    return np.arange(1, n + 1) * dt_s, speeds / steady.speed_rpm - 1.0


def test_the_rotor_follows_its_linear_block(operating_point):
    """J dx/dt = m - e x (paper 000 eqs. (8), (13)) with J, e of the rotor's block: x = (m/e)(1 - exp(-e t/J)). The
    rotor is the explicit Euler step of the same linear equation (per unit of the rated point; the torque and speed
    bases only rescale it), so the difference is Euler's: at most (m/e) (e dt/J) / (2 e_Napier) over the response,
    2.0e-5 of m/e at dt = 1 ms, J = 11.25 s, e = 1.25 (measured 2.04e-5): the tolerance 1e-4 of m/e holds it."""
    plant, steady, schedules = operating_point
    block = SHAFTS.linear_counterpart(shaft_section(plant)[0], plant, steady)
    j, e = block.values["inertia_time_s"], block.values["self_regulation"]
    assert block.units == {"inertia_time_s": "s", "self_regulation": "pu torque/pu speed"}
    m = 0.01
    t, x = _rotor_response(plant, steady, schedules, m, 1e-3, 20.0)
    linear = m / e * (1.0 - np.exp(-e * t / j))
    assert np.max(np.abs(x - linear)) < 1e-4 * m / e
    # the failing case: the block at the rated point (J = Ta, e = e_g, without M_r/M0 and n0/n_r) is 25 % off
    rated = m / plant.generator.self_regulation * (1.0 - np.exp(-plant.generator.self_regulation * t
                                                               / plant.generator.inertia_time_s))
    assert np.max(np.abs(x - rated)) > 0.1 * m / e


def test_the_rigid_column_follows_its_linear_block(operating_point):
    """h = -Tw dq/dt - r_f q (paper 000 eq. (9), with the linearized friction) under a flow ramp q = r t: the head is
    h = -Tw r - r_f r t. The rigid model computes the same column in physical units (backward Euler of the inertia,
    exact for a ramp) with the quadratic loss K Q|Q| at the previous step's flow: the differences are the loss's
    curvature (r_f/2) q^2 and its one-step lag r_f r dt, below 1e-5 here against |h| ~ 1e-2; the tolerance 1e-3 of
    |h| holds them with margin."""
    plant, steady, schedules = operating_point
    dt = 0.01
    block = PENSTOCKS.linear_counterpart("rigid", plant, steady)
    tw, rf = block.values["water_time_s"], block.values["friction_slope"]
    assert block.values["wave_time_s"] == 0.0 and rf > 0.0
    pen = PENSTOCKS.builder("rigid")(plant, steady, dt, plant.penstock.static_head_m)
    relation, update = pen.functions["relation"].py_func, pen.functions["update"].py_func
    rate = 0.01  # q = 1 % of Q0 per second, for 2 s
    head_up = plant.penstock.static_head_m
    heads, qs = [], []
    for k in range(1, 201):
        q = rate * k * dt
        flow = steady.flow_m3_s * (1.0 + q)
        c_l, slope = relation(pen.params, pen.state, head_up)
        head = c_l + slope * flow
        update(pen.params, pen.state, head_up, head, flow)
        heads.append(head / steady.head_m - 1.0)
        qs.append(q)
    h, q = np.array(heads), np.array(qs)
    linear = -tw * rate - rf * q
    assert np.max(np.abs(h - linear)) < 1e-3 * np.max(np.abs(h))
    # the failing case: Tw at the rated point (L Q_r / (g A H_r)) instead of the operating point's
    t = plant.turbine
    tw_rated = plant.penstock.water_time_s(t.rated_flow_m3_s, t.rated_head_m)
    assert not math.isclose(tw_rated, tw, rel_tol=0.05)
    assert np.max(np.abs(h - (-tw_rated * rate - rf * q))) > 0.05 * np.max(np.abs(h))


def test_the_elastic_block_carries_the_wave_time_and_the_section_alpha(operating_point):
    """The models with waves are compared with the lumped elastic block: Te = sum L / a and the section's alpha; the
    water time and friction slope are the rigid column's (one implementation, :func:`_column`)."""
    plant, steady, _ = operating_point
    rigid = PENSTOCKS.linear_counterpart("rigid", plant, steady).values
    for model in ("moc", "zdomain", "lumped"):
        block = PENSTOCKS.linear_counterpart(model, plant, steady)
        assert block.values == {**rigid, "wave_time_s": plant.penstock.travel_time_s,
                                "alpha": plant.penstock.lumped_alpha}
        assert "15" in block.equation  # paper 000 eqs. (15)-(18)
