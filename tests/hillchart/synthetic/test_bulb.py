"""The synthetic double-regulated bulb turbine and its model-test table (hillchart.synthetic.bulb,
hillsim synth --turbine bulb)."""

import numpy as np
import pytest
from scipy.optimize import brentq

from hillchart.synthetic.bulb import (BLADE_RANGE_DEG, GUIDE_VANE_RANGE_DEG, TABLE_COLUMNS, TRUTH_COLUMNS,
                                      BulbParameters,
                            SyntheticBulb, write_bulb_table)
from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import InputError
from hillchart.fccm.table import load_test_table
from hillsim.cli import main


@pytest.fixture(scope="module")
def grid():
    bulb = SyntheticBulb()
    blade, gv = np.meshgrid(np.linspace(*BLADE_RANGE_DEG, 35), np.linspace(*GUIDE_VANE_RANGE_DEG, 39), indexing="ij")
    return bulb, blade, gv, bulb.operate(blade, gv)


def test_closed_form_operating_point_matches_root_finding_on_the_unit_characteristic(grid):
    """Independent path: the unit characteristic Q11(n11) scaled by eqs. (1)-(2) of paper 003 and the system curve
    H = H_static - K Q^2 solved by Brent's method must give the closed-form operating point."""
    bulb, blade, gv, op = grid
    p = bulb.params
    d, n = p.runner_diameter_m, p.speed_rpm
    for i, j in [(0, 0), (34, 38), (17, 19), (5, 30), (30, 5)]:
        def residual(h):
            q = float(bulb.q11(n * d / np.sqrt(h), gv[i, j], blade[i, j])) * d * d * np.sqrt(h)
            return p.static_head_m - p.system_loss_s2_m5 * q * q - h
        head = brentq(residual, 1e-3, p.static_head_m, xtol=1e-14, rtol=1e-15)
        # 1e-9 relative: both are exact up to rounding (Brent to 1e-14 m)
        assert op.head_m[i, j] == pytest.approx(head, rel=1e-9)
        m11 = float(bulb.m11(n * d / np.sqrt(head), gv[i, j], blade[i, j]))
        power_kw = m11 * d ** 3 * head * n * 2 * np.pi / 60 / 1e3  # M = M11 D^3 H
        assert op.power_kw[i, j] == pytest.approx(power_kw, rel=1e-9)


def test_energy_balance_closes(grid):
    """Power + losses = rho g Q H: efficiency = P / (rho g Q H) as returned, and below 1 everywhere."""
    _, _, _, op = grid
    eta = op.power_kw * 1e3 / (RHO_WATER_KG_M3 * G_M_S2 * op.flow_m3_s * op.head_m)
    np.testing.assert_allclose(op.efficiency, eta, rtol=1e-12)
    assert 0.5 < op.efficiency.min() and op.efficiency.max() < 0.95  # a real machine's range (0.92 best, 0.55 corner)


def test_physical_trends(grid):
    """Opening either control admits more water; more water lowers the head on the water system; the best point
    lies inside the control range with the on-cam blade angle rising with the guide-vane angle."""
    bulb, blade, gv, op = grid
    assert np.all(np.diff(op.flow_m3_s, axis=0) > 0) and np.all(np.diff(op.flow_m3_s, axis=1) > 0)
    order = np.argsort(op.flow_m3_s.ravel())
    assert np.all(np.diff(op.head_m.ravel()[order]) < 0)
    blade_ratio = float(bulb.operate(16.0, 59.0).flow_m3_s / bulb.operate(-18.0, 59.0).flow_m3_s)
    vane_ratio = float(bulb.operate(0.0, 78.0).flow_m3_s / bulb.operate(0.0, 40.0).flow_m3_s)
    assert blade_ratio > 7.0 and 1.8 < vane_ratio < 2.5  # 7.2 and 2.1: the blades carry the flow control
    on_cam = blade[np.argmax(op.efficiency, axis=0), 0]
    assert on_cam[-1] > on_cam[0] + 4  # -14 deg at beta = 40, about -6 deg at beta = 78
    assert op.efficiency.max() > 0.9


def test_unit_quantities_follow_eqs_1_and_2(grid):
    bulb, _, _, op = grid
    d, n = bulb.params.runner_diameter_m, bulb.params.speed_rpm
    np.testing.assert_allclose(op.n11_rpm, n * d / np.sqrt(op.head_m), rtol=1e-14)
    np.testing.assert_allclose(op.q11_m3_s, op.flow_m3_s / (d * d * np.sqrt(op.head_m)), rtol=1e-14)


def test_bad_parameters_and_controls():
    with pytest.raises(InputError, match="hub_ratio"):
        BulbParameters(hub_ratio=1.2)
    with pytest.raises(InputError, match="k_incidence"):
        BulbParameters(k_incidence=1.5, k_swirl=0.6)
    with pytest.raises(InputError, match="beta2_deg"):
        BulbParameters(beta2_deg=10.0)  # 10 - 18 < 0 deg at the closed end of the blade range
    with pytest.raises(InputError, match="system_loss_s2_m5"):
        BulbParameters(system_loss_s2_m5=-1.0)
    with pytest.raises(InputError, match="speed_rpm"):
        BulbParameters(speed_rpm=float("nan"))
    bulb = SyntheticBulb()
    with pytest.raises(InputError, match="blade_angle_deg"):
        bulb.operate(20.0, 50.0)
    with pytest.raises(InputError, match="guide_vane_deg"):
        bulb.operate(0.0, 30.0)  # below the closed position (35 deg)


def test_table_is_scattered_noisy_and_reproducible(tmp_path):
    a = write_bulb_table(tmp_path / "a", seed=3)
    b = write_bulb_table(tmp_path / "b", seed=3)
    for name in a:
        assert a[name].read_bytes() == b[name].read_bytes()  # same seed, same bytes
    c = write_bulb_table(tmp_path / "c", seed=4)
    assert c["table.csv"].read_bytes() != a["table.csv"].read_bytes()
    table = load_test_table(tmp_path / "a")
    assert table.n_rows == 150 and set(TABLE_COLUMNS) <= set(table.columns)
    assert table.derived == ("n11_rpm", "q11_m3_s")
    blade, gv = table.column("blade_angle_deg"), table.column("guide_vane_deg")
    assert np.unique(blade).size > 100 and np.unique(gv).size > 100  # scattered, not a grid
    assert blade.min() == BLADE_RANGE_DEG[0] and gv.max() == GUIDE_VANE_RANGE_DEG[1]  # corners included
    exact = SyntheticBulb().operate(blade, gv)
    rel = table.column("head_m") / exact.head_m - 1
    # noise 0.3 % std: sample std within 20 % of it for 150 points (chi distribution, 3.5 sigma band is +-20 %)
    assert 0.0024 < np.std(rel) < 0.0036
    # the derived unit quantities carry the head noise only through sqrt(H): within 1 % of the exact ones
    np.testing.assert_allclose(table.column("n11_rpm"), exact.n11_rpm, rtol=0.01)


def test_noise_free_table_equals_the_truth_to_the_written_digits(tmp_path):
    write_bulb_table(tmp_path, seed=0, noise=0.0, n_points=20, closure="best-efficiency")
    table = load_test_table(tmp_path)
    exact = SyntheticBulb().best_efficiency_points(table.column("blade_angle_deg"), table.column("guide_vane_deg"))
    np.testing.assert_allclose(table.column("head_m"), exact.head_m, atol=0.5e-4)  # 4 decimals written
    np.testing.assert_allclose(table.column("efficiency"), exact.efficiency, atol=2e-5)  # 5 decimals + P, Q, H rounding
    truth = np.genfromtxt(tmp_path / "truth.csv", delimiter=",", names=True)
    assert truth.dtype.names == TRUTH_COLUMNS and truth.size == 69 * 77  # 0.5 deg grid over the paper's ranges


def test_propeller_curve_table_measures_each_setting_at_every_unit_speed(tmp_path):
    from hillchart.synthetic.bulb import PROPELLER_N11_RPM

    write_bulb_table(tmp_path, seed=0, noise=0.0, n_points=100, closure="propeller-curves", truth_step_deg=5.0)
    table = load_test_table(tmp_path)
    assert table.n_rows == 100  # 20 settings x 5 unit speeds
    n11 = table.column("n11_rpm").reshape(20, len(PROPELLER_N11_RPM))
    # the loader derives N11 from the written head (4 decimals): the propeller curves' speeds to 1e-4 relative
    np.testing.assert_allclose(n11, np.broadcast_to(PROPELLER_N11_RPM, n11.shape), rtol=1e-4)
    blade = table.column("blade_angle_deg").reshape(20, -1)
    assert np.all(blade == blade[:, :1])  # one setting per curve
    exact = SyntheticBulb().unit_efficiency(n11.ravel(), table.column("guide_vane_deg"), blade.ravel())
    np.testing.assert_allclose(table.column("efficiency"), exact, atol=2e-5)  # 5 decimals + P, Q, H rounding
    with pytest.raises(InputError, match="n11_rpm must be a non-empty list of positive unit speeds"):
        SyntheticBulb().propeller_points(0.0, 50.0, n11_rpm=[150.0, -1.0])


def test_best_efficiency_closure_is_the_optimum_of_each_propeller_curve():
    """The golden-section optimum against a 0.01 r/min scan, and its stationarity."""
    bulb = SyntheticBulb()
    n = np.linspace(20.0, 400.0, 38001)
    for blade, gv in [(-18.0, 40.0), (16.0, 78.0), (0.0, 55.0), (-10.0, 70.0), (16.0, 40.0)]:
        best = float(bulb.best_efficiency_n11(blade, gv))
        assert best == pytest.approx(n[np.argmax(bulb.unit_efficiency(n, gv, blade))], abs=0.011)  # scan step
        def eta(x, gv=gv, blade=blade):
            return float(bulb.unit_efficiency(x, gv, blade))

        assert eta(best) >= max(eta(best - 0.05), eta(best + 0.05))
    op = bulb.best_efficiency_points(np.array([-5.0, 5.0]), np.array([50.0, 60.0]))
    d, speed = bulb.params.runner_diameter_m, bulb.params.speed_rpm
    np.testing.assert_allclose(op.n11_rpm, speed * d / np.sqrt(op.head_m), rtol=1e-13)  # eq. (2)
    np.testing.assert_allclose(op.q11_m3_s, op.flow_m3_s / (d * d * np.sqrt(op.head_m)), rtol=1e-13)  # eq. (1)


def test_water_system_closure_puts_every_setting_on_one_curve_of_the_fccm(grid):
    """Why the test table uses the best-efficiency closure: on a passive water system H(Q), n11 and Q11 are both
    functions of Q, so n11 is one function of Q11 (a line in the FCCM plane); the best-efficiency closure is 2-D."""
    bulb, blade, gv, op = grid
    order = np.argsort(op.q11_m3_s.ravel())
    assert np.all(np.diff(op.n11_rpm.ravel()[order]) >= 0)  # a monotone curve n11(Q11): no 2-D spread
    best = bulb.best_efficiency_points(blade, gv)
    order = np.argsort(best.q11_m3_s.ravel())
    assert np.sum(np.diff(best.n11_rpm.ravel()[order]) < 0) > 100  # n11 is not a function of Q11 here


def test_bad_table_options_leave_nothing(tmp_path):
    with pytest.raises(InputError, match="noise"):
        write_bulb_table(tmp_path / "x", noise=-0.1)
    with pytest.raises(InputError, match="n_points"):
        write_bulb_table(tmp_path / "y", n_points=5)
    with pytest.raises(InputError, match="closure"):
        write_bulb_table(tmp_path / "z", closure="on-cam")
    assert not any((tmp_path / n).exists() for n in "xyz")


def test_cli_synth_bulb(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "bulb"), "--turbine", "bulb", "--seed", "1", "--points", "60"]) == 0
    assert load_test_table(tmp_path / "bulb").n_rows == 60
    assert main(["synth", str(tmp_path / "bad"), "--turbine", "bulb", "--noise", "50"]) == 2
    assert "noise" in capsys.readouterr().err and not (tmp_path / "bad").exists()
    assert main(["synth", str(tmp_path / "francis")]) == 0  # the default is still the Francis chart
    assert (tmp_path / "francis" / "flow.csv").is_file()
    assert main(["synth", str(tmp_path / "z"), "--turbine", "pelton"]) == 2
    assert "--turbine must be one of slow, medium, fast, bulb" in capsys.readouterr().err
