"""Linear models from the six coefficients: paper formulas, cross-checks with scipy.signal, paper 002 maps."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig
from hypothesis import given, settings
from hypothesis import strategies as st

from hillchart.errors import InputError
from simulate.linear.models import (
    DEFAULT_ALPHA,
    ArxModel,
    LinearPlant,
    arma_coefficients,
    combined_coefficient,
    torque_transfer_function,
    turbine_parameters_from_arma,
)

# A Francis-like set with every coefficient non-trivial (signs as in paper 000 section 5.2)
FRANCIS = dict(ex=-0.8, ey=0.9, eh=1.4, eqx=0.2, eqy=1.1, eqh=0.4)
IDEAL = dict(ex=-1.0, ey=1.0, eh=1.5, eqx=0.0, eqy=1.0, eqh=0.5)
TW, TA, TE = 1.2, 7.0, 0.3

VARIANTS = [
    dict(),
    dict(wave_time_s=TE),
    dict(self_regulation=0.5),
    dict(wave_time_s=TE, self_regulation=0.5, friction_slope=0.05),
    dict(friction_slope=0.05),
]


def plant(coeffs=FRANCIS, **kw):
    return LinearPlant(**coeffs, water_time_s=TW, inertia_time_s=TA, **kw)


def test_n2_d2_are_paper_eqs_43_44():
    # paper 000 eqs. (43)-(44) written out term by term (rigid water, no grid damping)
    ex, eu, eh, eqx, equ, eqh = FRANCIS.values()
    d2 = [TW * eqh * TA, TA + TW * (eh * eqx - ex * eqh), -ex]
    n2 = [(eu * eqh - equ * eh) * TW, eu]
    num, den = plant().speed_transfer_function()
    np.testing.assert_allclose(den, d2, rtol=1e-14)
    np.testing.assert_allclose(num, n2, rtol=1e-14)


def test_n3_d3_are_paper_eqs_51_52():
    ex, eu, eh, eqx, equ, eqh = FRANCIS.values()
    aT2 = DEFAULT_ALPHA * TE**2
    d3 = [aT2 * TA, TA * TW * eqh - ex * aT2, TA - ex * TW * eqh + eh * TW * eqx, -ex]  # eq. (51)
    n3 = [eu * aT2, eu * TW * eqh - TW * equ * eh, eu]  # eq. (52)
    num, den = plant(wave_time_s=TE).speed_transfer_function()
    np.testing.assert_allclose(den, d3, rtol=1e-14)
    np.testing.assert_allclose(num, n3, rtol=1e-14)


def test_inelastic_matrices_are_paper_eq_12():
    ex, eu, eh, eqx, equ, eqh = FRANCIS.values()
    ss = plant().state_space()
    J = TA
    np.testing.assert_allclose(ss.A, [[ex / J, eh / J],
                                      [-eqx * ex / (eqh * J), -(eh * eqx / (eqh * J) + 1 / (eqh * TW))]], rtol=1e-14)
    np.testing.assert_allclose(ss.B1, [eu / J, -eqx * eu / (eqh * J)], rtol=1e-14)
    np.testing.assert_allclose(ss.B2, [0.0, -equ / eqh], rtol=1e-14)
    np.testing.assert_allclose(ss.L0, [-1 / J, eqx / (eqh * J)], rtol=1e-14)


@pytest.mark.parametrize("kw", VARIANTS)
def test_state_space_and_transfer_functions_agree(kw):
    # cross-check between implementations: matrices (eqs. 12 / 28-30) vs polynomial algebra (eqs. 43-52)
    p = plant(**kw)
    A, B, C, D = p.state_space().single_input()
    num, den = sig.ss2tf(A, B, C, D)
    n_x, d_x = p.speed_transfer_function()
    n_h, d_h = p.head_transfer_function()
    scale = d_x[0] / den[0]
    np.testing.assert_allclose(den * scale, d_x, rtol=1e-12)
    np.testing.assert_allclose(num[0] * scale, np.pad(n_x, (den.size - n_x.size, 0)), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(num[1] * scale, np.pad(n_h, (den.size - n_h.size, 0)), rtol=1e-10, atol=1e-12)
    # open-loop eigenvalues are the roots of D2 / D3
    np.testing.assert_allclose(np.sort_complex(p.state_space().eigenvalues()), np.sort_complex(np.roots(d_x)),
                               rtol=1e-9)


def test_stability_flag():
    assert plant().state_space().is_stable()
    assert plant(wave_time_s=TE).state_space().is_stable()
    # a turbine whose torque rises with speed (ex > 0, no grid damping) runs away: one eigenvalue > 0
    unstable = plant(dict(FRANCIS, ex=0.3))
    assert not unstable.state_space().is_stable()
    assert max(np.real(unstable.state_space().eigenvalues())) > 0
    # ... unless the grid's self-regulation e_g exceeds ex (eq. 13)
    assert plant(dict(FRANCIS, ex=0.3), self_regulation=0.8).state_space().is_stable()


@pytest.mark.parametrize("kw", VARIANTS)
def test_zoh_matches_scipy_cont2discrete(kw):
    ss = plant(**kw).state_space()
    disc = ss.discretize(0.2)
    B = np.column_stack([ss.B1, ss.B2, ss.L0])
    G, H, *_ = sig.cont2discrete((ss.A, B, np.eye(ss.A.shape[0]), np.zeros_like(B)), 0.2, method="zoh")
    np.testing.assert_allclose(disc.G, G, rtol=1e-12, atol=1e-14)  # eq. (33)
    np.testing.assert_allclose(np.column_stack([disc.HB1, disc.HB2, disc.HL]), H, rtol=1e-11, atol=1e-14)


@pytest.mark.parametrize("kw", VARIANTS)
def test_step_response_matches_scipy_signal(kw):
    # a step is held exactly by a zero-order hold: sampled continuous response == discrete response to round-off
    p = plant(**kw)
    t = np.arange(151) * 0.2
    resp = p.step_response(0.2, 150, amplitude=0.01)
    for col, (num, den) in enumerate([p.speed_transfer_function(), p.head_transfer_function()]):
        _, y = sig.step((num, den), T=t)
        assert np.max(np.abs(resp[:, col] - 0.01 * y)) < 1e-12 * max(1.0, np.max(np.abs(y)))
    # speed settles at ey / (e_g - ex) of the step (rigid and lumped alike; friction changes it)
    if kw.get("friction_slope", 0) == 0:
        ex = FRANCIS["ex"] - kw.get("self_regulation", 0.0)
        final = p.step_response(0.2, 1000, amplitude=0.01)[-1, 0]  # 200 s, > 20 times the slowest time constant
        assert final == pytest.approx(0.01 * FRANCIS["ey"] / -ex, rel=1e-6)


@pytest.mark.parametrize("kw", VARIANTS)
def test_arx_coefficients_match_cont2discrete_and_reproduce_the_step(kw):
    p = plant(**kw)
    arx = p.arx(0.2)
    num, den = p.speed_transfer_function()
    nd, dd, _ = sig.cont2discrete((num, den), 0.2, method="zoh")
    nd, dd = np.ravel(nd) / dd[0], dd / dd[0]
    np.testing.assert_allclose(arx.a, -dd[1:], rtol=1e-9)
    np.testing.assert_allclose(arx.b, nd[1:], rtol=1e-8, atol=1e-14)
    n_order = 3 if p.elastic else 2
    assert arx.n_a == n_order and arx.n_b == n_order and arx.input_delay == 0
    np.testing.assert_allclose(arx.step_response(100), p.step_response(0.2, 100)[:, 0], atol=1e-12)


def test_discrete_simulation_of_a_prbs_matches_lsim():
    # the exact jump form X(k+1) = G X + HB1 y + B2 (y(k+1) - y(k)) against scipy.signal.lsim on a fine grid
    p = plant(wave_time_s=TE)
    rng = np.random.default_rng(0)
    y = 0.01 * rng.choice([-1.0, 1.0], size=60)
    states = p.state_space().discretize(0.2).simulate(y)
    A, B, C, D = p.state_space().single_input()
    t = np.arange(60 * 40 + 1) * 0.005
    u = np.repeat(y, 40)
    u = np.r_[u, u[-1]]
    _, out, _ = sig.lsim((A, B, C, D), u, t, interp=False)
    # lsim with interp=False holds the input (zero-order hold): both are exact, differences are round-off
    np.testing.assert_allclose(states[1:, 0], out[40::40, 0], atol=1e-12)


def test_paper_002_ideal_turbine_gives_eq_4():
    e = combined_coefficient(tuple(IDEAL.values()))
    assert e == 1.0
    num, den = torque_transfer_function(ey=1.0, e=e, eqh=0.5, water_time_s=TW)
    np.testing.assert_allclose(num, [-TW, 1.0])  # 1 - Tw s
    np.testing.assert_allclose(den, [0.5 * TW, 1.0])  # 1 + 0.5 Tw s


def test_paper_002_model_is_the_six_coefficient_torque_at_constant_speed():
    # m/y with x = 0: ey + eh h/y, h/y = -Tw s eqy / (1 + eqh Tw s); must equal ey (1 - e Tw s)/(1 + eqh Tw s)
    ex, ey, eh, eqx, eqy, eqh = FRANCIS.values()
    num, den = torque_transfer_function(ey=ey, e=combined_coefficient(tuple(FRANCIS.values())), eqh=eqh,
                                        water_time_s=TW)
    direct = np.polyadd(ey * np.array([eqh * TW, 1.0]), -eh * eqy * np.array([TW, 0.0]))
    np.testing.assert_allclose(num, direct, rtol=1e-14)


def test_arma_difference_equation_is_backward_euler_of_eq_3():
    # eq. (6) converges to the continuous step response of eq. (3) as Dt -> 0 (first order in Dt)
    ey, e, eqh = 1.2, 0.9, 0.45
    num, den = torque_transfer_function(ey=ey, e=e, eqh=eqh, water_time_s=TW)
    errors = []
    for dt in (0.02, 0.01):
        a, b, c = arma_coefficients(ey=ey, e=e, eqh=eqh, water_time_s=TW, sample_time_s=dt)
        n = int(round(3.0 / dt))
        m = np.zeros(n + 1)
        y = np.ones(n + 1)
        y[0] = 0.0
        for k in range(1, n + 1):
            m[k] = -a * m[k - 1] + b * y[k] + c * y[k - 1]  # eq. (7)
        t = np.arange(1, n + 1) * dt
        _, ref = sig.step((num, den), T=t)
        errors.append(np.max(np.abs(m[1:] - ref)))
    assert errors[1] < 0.6 * errors[0]  # halving Dt roughly halves the error (first order)
    assert errors[1] < 0.05 * ey * (1 + e / eqh)  # and it is small against the initial jump -ey e / eqh


@settings(max_examples=60, deadline=None)
@given(ey=st.floats(0.2, 2.0), e=st.floats(0.05, 2.0), eqh=st.floats(0.1, 1.0), tw=st.floats(0.3, 5.0),
       dt=st.floats(0.01, 0.5))
def test_arma_round_trip(ey, e, eqh, tw, dt):
    a, b, c = arma_coefficients(ey=ey, e=e, eqh=eqh, water_time_s=tw, sample_time_s=dt)
    back = turbine_parameters_from_arma(a, b, c, water_time_s=tw, sample_time_s=dt)
    # the inverse of eq. (8) is algebraically exact; 1e-9 relative covers round-off of the divisions
    np.testing.assert_allclose(back, (ey, e, eqh), rtol=1e-9)


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("water_time_s", 0.0, "water_time_s must be finite and > 0"),
        ("water_time_s", float("nan"), "water_time_s"),
        ("inertia_time_s", -2.0, "inertia_time_s must be finite and > 0"),
        ("self_regulation", -0.1, "self_regulation must be finite and >= 0"),
        ("wave_time_s", -0.3, "wave_time_s must be finite and >= 0"),
        ("alpha", 0.0, "alpha must be finite and > 0"),
        ("friction_slope", "abc", "friction_slope must be a number"),
        ("water_time_s", True, "water_time_s must be a number, got True"),  # a bool is not a number
        ("water_time_s", "3", "water_time_s must be a number, got '3'"),  # nor is a numeric string
        ("ex", float("inf"), "coefficient ex must be finite"),
        ("eqh", 0.0, "eqh must be != 0"),
    ],
)
def test_bad_linear_plant_is_rejected(field, value, match):
    kwargs = dict(FRANCIS, water_time_s=TW, inertia_time_s=TA)
    kwargs[field] = value
    with pytest.raises(InputError, match=match):
        LinearPlant(**kwargs)


def test_from_coefficients_accepts_records_dicts_and_sequences():
    ref = plant()
    assert LinearPlant.from_coefficients(FRANCIS, water_time_s=TW, inertia_time_s=TA) == ref
    assert LinearPlant.from_coefficients(list(FRANCIS.values()), water_time_s=TW, inertia_time_s=TA) == ref
    with pytest.raises(InputError, match="missing"):
        LinearPlant.from_coefficients({"ex": 1.0}, water_time_s=TW, inertia_time_s=TA)
    with pytest.raises(InputError, match="6 values"):
        LinearPlant.from_coefficients([1.0, 2.0], water_time_s=TW, inertia_time_s=TA)


def test_bad_discretization_and_arma_inputs_are_rejected():
    with pytest.raises(InputError, match="sample_time_s"):
        plant().state_space().discretize(0.0)
    with pytest.raises(InputError, match="n_samples"):
        plant().step_response(0.2, 0)
    with pytest.raises(InputError, match="a must be != -1"):
        turbine_parameters_from_arma(-1.0, 0.1, 0.2, water_time_s=1.0, sample_time_s=0.1)
    with pytest.raises(InputError, match="b \\+ c != 0"):
        turbine_parameters_from_arma(-0.5, 0.1, -0.1, water_time_s=1.0, sample_time_s=0.1)
    with pytest.raises(InputError, match="sample_time_s"):
        arma_coefficients(ey=1.0, e=1.0, eqh=0.5, water_time_s=1.0, sample_time_s=-0.1)
    with pytest.raises(InputError, match="ey must be != 0"):
        combined_coefficient((-1.0, 0.0, 1.5, 0.0, 1.0, 0.5))
    with pytest.raises(InputError, match="input_delay"):
        ArxModel(a=[0.5], b=[1.0], input_delay=-1)
    with pytest.raises(InputError, match="n_a \\+ n_b"):
        ArxModel.from_theta([1.0, 2.0, 3.0], n_a=3, n_b=2)
    with pytest.raises(InputError, match="load must have"):
        plant().state_space().discretize(0.2).simulate([0.1, 0.1], load=[0.0])
