"""Six coefficients from characteristics: analytic truth, finite differences, the head derivation, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hillchart.characteristics import IdealTurbine
from hillchart.errors import InputError
from hillchart.linearize import (
    COEFFICIENT_NAMES,
    SixCoefficients,
    coefficient_maps,
    plot_coefficient_maps,
    six_coefficients,
    six_coefficients_at,
)

IDEAL = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.92)


class SmoothTurbine:
    """A nonlinear analytic test characteristic (Francis-like shapes, all six coefficients non-trivial)."""

    def q11(self, n11, a):
        n11, a = np.broadcast_arrays(np.asarray(n11, float), np.asarray(a, float))
        return 0.02 * a * (1.0 + 0.004 * (n11 - 70.0)) * np.exp(-0.01 * a)

    def m11(self, n11, a):
        n11, a = np.broadcast_arrays(np.asarray(n11, float), np.asarray(a, float))
        return 30.0 * a * (1.0 - (n11 / 120.0) ** 2) + 0.05 * a**2

    def q11_grad(self, n11, a):
        n11, a = np.broadcast_arrays(np.asarray(n11, float), np.asarray(a, float))
        dq_dn = 0.02 * a * 0.004 * np.exp(-0.01 * a)
        dq_da = 0.02 * (1.0 + 0.004 * (n11 - 70.0)) * np.exp(-0.01 * a) * (1.0 - 0.01 * a)
        return dq_dn, dq_da

    def m11_grad(self, n11, a):
        n11, a = np.broadcast_arrays(np.asarray(n11, float), np.asarray(a, float))
        return -60.0 * a * n11 / 120.0**2, 30.0 * (1.0 - (n11 / 120.0) ** 2) + 0.1 * a


def fd_coefficients(turbine, n11, a, rel=1e-5):
    """Six coefficients by central differences of Q11, M11 and the model-law head scaling (independent route)."""
    def d(f, which):
        hn, ha = (n11 * rel, 0.0) if which == "n" else (0.0, a * rel)
        return (float(f(n11 + hn, a + ha)) - float(f(n11 - hn, a - ha))) / (2 * (hn + ha))

    q, m = float(turbine.q11(n11, a)), float(turbine.m11(n11, a))
    ex, ey = n11 / m * d(turbine.m11, "n"), a / m * d(turbine.m11, "a")
    eqx, eqy = n11 / q * d(turbine.q11, "n"), a / q * d(turbine.q11, "a")
    return ex, ey, eqx, eqy


def physical_head_coefficients(turbine, *, n_rpm, head_m, d1_m, a, rel=1e-6):
    """eh, eqh straight from M = M11(n D1/sqrt(H), a) D1^3 H and Q = Q11(..) D1^2 sqrt(H) by central differences in H:
    checks the derivation eh = 1 - ex/2, eqh = 1/2 - eqx/2 without using it."""
    def torque(h):
        return float(turbine.m11(n_rpm * d1_m / np.sqrt(h), a)) * d1_m**3 * h

    def flow(h):
        return float(turbine.q11(n_rpm * d1_m / np.sqrt(h), a)) * d1_m**2 * np.sqrt(h)

    dh = head_m * rel
    eh = (torque(head_m + dh) - torque(head_m - dh)) / (2 * dh) * head_m / torque(head_m)
    eqh = (flow(head_m + dh) - flow(head_m - dh)) / (2 * dh) * head_m / flow(head_m)
    return eh, eqh


@pytest.mark.parametrize("n11, a", [(50.0, 5.0), (70.0, 15.0), (95.0, 29.0)])
def test_ideal_turbine_is_exact(n11, a):
    # analytic truth: Q11 ~ a, M11 ~ a/N11 give exactly (-1, 1, 1.5, 0, 1, 0.5); only round-off remains
    c = six_coefficients(IDEAL, n11=n11, opening=a)
    np.testing.assert_allclose(c.as_tuple(), (-1.0, 1.0, 1.5, 0.0, 1.0, 0.5), atol=1e-12)
    assert c.n11_rpm == n11 and c.opening == a
    assert c.e == pytest.approx(1.0, abs=1e-12)  # paper 002: e = eqy eh / ey - eqh = 1 for the ideal turbine


@pytest.mark.parametrize("n11, a", [(60.0, 8.0), (72.0, 20.0), (85.0, 27.0)])
def test_against_central_differences(n11, a):
    t = SmoothTurbine()
    c = six_coefficients(t, n11=n11, opening=a)
    ex, ey, eqx, eqy = fd_coefficients(t, n11, a)
    # central differences with rel. step 1e-5 have truncation ~1e-10 and round-off ~1e-11 relative
    np.testing.assert_allclose([c.ex, c.ey, c.eqx, c.eqy], [ex, ey, eqx, eqy], rtol=1e-7, atol=1e-9)
    assert c.eh == pytest.approx(1 - c.ex / 2, abs=1e-15)


def test_head_coefficients_follow_from_the_unit_scaling():
    # plant operating point in physical units (D1 = 4.5 m, H = 176 m, n = 200 r/min -> N11 = 67.84 r/min)
    t = SmoothTurbine()
    c = six_coefficients_at(t, speed_rpm=200.0, head_m=176.0, runner_diameter_m=4.5, opening=20.0)
    assert c.n11_rpm == pytest.approx(200.0 * 4.5 / np.sqrt(176.0), rel=1e-15)
    eh, eqh = physical_head_coefficients(t, n_rpm=200.0, head_m=176.0, d1_m=4.5, a=20.0)
    # independent route through M(H), Q(H): agreement to FD accuracy (~1e-8) proves eh = 1 - ex/2, eqh = 1/2 - eqx/2
    assert c.eh == pytest.approx(eh, abs=1e-7)
    assert c.eqh == pytest.approx(eqh, abs=1e-7)
    assert abs(c.eh - 1.0) > 0.05  # the check is not trivial: ex is far from 0 here


def test_result_record_round_trips_to_json():
    c = six_coefficients(SmoothTurbine(), n11=70.0, opening=15.0)
    d = json.loads(json.dumps(c.to_dict()))
    assert SixCoefficients(**d) == c
    assert list(d)[:6] == list(COEFFICIENT_NAMES)


def test_coefficient_maps_match_pointwise_and_mark_invalid_points():
    t = SmoothTurbine()
    n11 = np.array([55.0, 70.0, 90.0, 120.0])  # at N11 = 120 and a -> M11 = 30 a * 0 + 0.05 a^2: still nonzero
    a = np.array([5.0, 15.0, 25.0])
    maps = coefficient_maps(t, n11, a)
    assert maps["ex"].shape == (3, 4)
    for i, ai in enumerate(a):
        for j, nj in enumerate(n11):
            np.testing.assert_allclose([maps[k][i, j] for k in COEFFICIENT_NAMES],
                                       six_coefficients(t, n11=nj, opening=ai).as_tuple(), rtol=1e-13)

    class ZeroTorqueAt(SmoothTurbine):
        def m11(self, n11, a):
            m = super().m11(n11, a)
            return np.where(np.asarray(n11) == 90.0, 0.0, m)

    maps = coefficient_maps(ZeroTorqueAt(), n11, a)
    assert np.all(np.isnan(maps["ex"][:, 2])) and np.all(np.isfinite(maps["ex"][:, [0, 1, 3]]))
    assert np.all(np.isfinite(maps["eqx"]))  # flow side is unaffected


def test_plot_coefficient_maps_writes_png(tmp_path):
    maps = coefficient_maps(SmoothTurbine(), np.linspace(50, 100, 12), np.linspace(4, 30, 10))
    out = tmp_path / "maps.png"
    fig = plot_coefficient_maps(maps, out, operating_point=(70.0, 15.0), opening_unit="mm")
    assert out.stat().st_size > 10_000
    assert len(fig.axes) >= 6
    with pytest.raises(InputError, match="missing keys"):
        plot_coefficient_maps({"n11": [1.0]})


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n11=0.0, opening=10.0), "n11 must be > 0"),
        (dict(n11=-5.0, opening=10.0), "n11 must be > 0"),
        (dict(n11=float("nan"), opening=10.0), "n11 must be finite"),
        (dict(n11=70.0, opening=0.0), "opening must be > 0"),
        (dict(n11=70.0, opening=float("inf")), "opening must be finite"),
        (dict(n11=[70.0, 80.0], opening=10.0), "n11 must be a scalar"),
        (dict(n11=70.0, opening=[1.0, 2.0]), "opening must be a scalar"),
    ],
)
def test_bad_operating_point_is_rejected(kwargs, match):
    with pytest.raises(InputError, match=match):
        six_coefficients(IDEAL, **kwargs)


def test_zero_flow_or_torque_at_the_point_is_rejected():
    class NoFlow(SmoothTurbine):
        def q11(self, n11, a):
            return 0.0 * super().q11(n11, a)

    with pytest.raises(InputError, match="Q11 at"):
        six_coefficients(NoFlow(), n11=70.0, opening=10.0)


@pytest.mark.parametrize("field, value", [("speed_rpm", 0.0), ("head_m", -1.0), ("runner_diameter_m", float("nan")),
                                          ("head_m", [1.0, 2.0])])
def test_bad_plant_point_is_rejected(field, value):
    kwargs = dict(speed_rpm=200.0, head_m=176.0, runner_diameter_m=4.5, opening=20.0)
    kwargs[field] = value
    with pytest.raises(InputError, match=field):
        six_coefficients_at(IDEAL, **kwargs)


def test_bad_map_grid_is_rejected():
    with pytest.raises(InputError, match="opening must be > 0"):
        coefficient_maps(IDEAL, [60.0, 70.0], [0.0, 10.0])
    with pytest.raises(InputError, match="at least one"):
        coefficient_maps(IDEAL, [], [10.0])


def test_synthetic_francis_at_rated_point_matches_finite_differences():
    from hillchart.synthetic.francis import SyntheticFrancis

    t = SyntheticFrancis()
    c = six_coefficients(t, n11=67.8, opening=23.46)  # HLA339-like rated point (Q11 = 0.53 m^3/s)
    ex, ey, eqx, eqy = fd_coefficients(t, 67.8, 23.46)
    # the synthetic turbine's derivatives are complex-step exact; central differences agree to ~1e-8
    np.testing.assert_allclose([c.ex, c.ey, c.eqx, c.eqy], [ex, ey, eqx, eqy], rtol=1e-6, atol=1e-8)
    # a real Francis at rated: torque falls with speed, and steeper than the ideal turbine's -1
    assert -1.3 < c.ex < -1.0 and 0 < c.ey < 1 and abs(c.eqx) < 0.1 and 0.45 < c.eqh < 0.55


def test_nets_trained_on_an_ideal_chart_give_the_ideal_coefficients():
    from hillchart.nets.estimator import HillNet
    from hillchart.nets.hill_nets import HillNets

    # an ideal-turbine "chart" on a band of N11 away from 0 (Q11 = k a, M11 = c a / N11), both nets trained by LM
    n, a = np.meshgrid(np.linspace(50, 90, 15), np.linspace(5, 30, 12))
    X = np.column_stack([n.ravel(), a.ravel()])
    flow = HillNet(restarts=3, seed=0, goal=1e-8).fit(X, IDEAL.q11(X[:, 0], X[:, 1]))
    torque = HillNet(restarts=3, seed=1, goal=1e-8).fit(X, IDEAL.m11(X[:, 0], X[:, 1]))
    nets = HillNets(flow=flow.weights_, torque=torque.weights_, opening_unit="mm")
    worst = 0.0
    for n11 in (55.0, 62.0, 70.0, 78.0, 85.0):
        for opening in (8.0, 14.0, 20.0, 26.0):
            c = six_coefficients(nets, n11=n11, opening=opening)
            worst = max(worst, np.max(np.abs(np.array(c.as_tuple()) - (-1.0, 1.0, 1.5, 0.0, 1.0, 0.5))))
    # the accuracy bound 0.02; measured 0.002 inside the band (0.019 at a corner sample, outside this grid)
    assert worst < 0.02


def test_shipped_synthetic_nets_at_rated_point_match_the_exact_turbine():
    from hillchart.nets.hill_nets import load_nets
    from hillchart.synthetic.francis import SyntheticFrancis

    from data_synthetic import FRANCIS_DIR

    nets = load_nets(FRANCIS_DIR / "nets.json")
    for n11, opening in ((67.8, 23.46), (67.3, 21.7), (60.0, 18.0), (75.0, 26.0)):  # rated (chart, plant) + nearby
        c_nets = six_coefficients(nets, n11=n11, opening=opening).as_tuple()
        c_true = six_coefficients(SyntheticFrancis(), n11=n11, opening=opening).as_tuple()
        # the accuracy bound 0.05; measured max 0.017 over these points (eqx and ex, the N11 slopes, are the hardest)
        np.testing.assert_allclose(c_nets, c_true, atol=0.05)
