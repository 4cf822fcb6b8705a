"""Eight transfer coefficients of a double-regulated turbine (``hillsim linearize`` with a blade angle)."""

import json

import numpy as np
import pytest

from data_synthetic import BULB_DIR
from hillchart.errors import InputError
from hillchart.fccm.double_regulated import load_double_regulated_nets
from hillchart.linearize import eight_coefficients, six_coefficients
from hillchart.synthetic.bulb import SyntheticBulb


class Linear3:
    """Q11 = q a (1 + c phi), constant efficiency: ex = -1, ey = 1, eqx = 0, eqy = 1, ephi = eqphi = c/(1 + c phi)."""

    c = 0.02

    def q11(self, n11, a, phi):
        return 0.02 * np.asarray(a) * (1 + self.c * np.asarray(phi)) + 0 * np.asarray(n11)

    def m11(self, n11, a, phi):
        return 9000.0 * self.q11(n11, a, phi) / np.asarray(n11)


def test_linear_turbine_gives_its_eight_coefficients():
    c = eight_coefficients(Linear3(), n11=150.0, opening=40.0, blade_angle=5.0)
    expected = (-1.0, 1.0, 1.5, 0.0, 1.0, 0.5, 0.02 / 1.1, 0.02 / 1.1)
    # central differences of a function linear in a and phi and ~1/n11 in n11: truncation ~1e-8 relative
    np.testing.assert_allclose(c.as_tuple(), expected, atol=1e-7)


def test_nets_analytic_coefficients_equal_central_differences_and_the_exact_bulb():
    nets = load_double_regulated_nets(BULB_DIR / "nets.json")
    point = {"n11": 150.0, "opening": 50.0, "blade_angle": -7.0}
    analytic = eight_coefficients(nets, **point)

    class NoGradient:  # the same nets without their analytic gradients: central differences
        q11, m11 = nets.q11, nets.m11

    numeric = eight_coefficients(NoGradient(), **point)
    # smooth nets, step 1e-4 relative: truncation ~1e-8, rounding ~1e-12 / 1e-4
    np.testing.assert_allclose(analytic.as_tuple(), numeric.as_tuple(), atol=1e-6)
    exact = eight_coefficients(SyntheticBulb(), **point)
    # the nets fit the bulb to 0.1 % RMS; their derivatives are good to a few % inside the training box
    np.testing.assert_allclose(analytic.as_tuple(), exact.as_tuple(), atol=0.03)
    assert abs(exact.ephi) > 0.01 and abs(exact.eqphi) > 0.01  # the blade angle matters at this point


def test_eight_coefficients_with_the_blade_held_are_the_six_of_the_fixed_blade_turbine():
    bulb = SyntheticBulb()

    class FixedBlade:
        def q11(self, n11, a):
            return bulb.q11(n11, a, -7.0)

        def m11(self, n11, a):
            return bulb.m11(n11, a, -7.0)

        def q11_grad(self, n11, a):
            h = 1e-4
            return ((self.q11(n11 * (1 + h), a) - self.q11(n11 * (1 - h), a)) / (2 * h * n11),
                    (self.q11(n11, a * (1 + h)) - self.q11(n11, a * (1 - h))) / (2 * h * a))

        def m11_grad(self, n11, a):
            h = 1e-4
            return ((self.m11(n11 * (1 + h), a) - self.m11(n11 * (1 - h), a)) / (2 * h * n11),
                    (self.m11(n11, a * (1 + h)) - self.m11(n11, a * (1 - h))) / (2 * h * a))

    six = six_coefficients(FixedBlade(), n11=150.0, opening=50.0)
    eight = eight_coefficients(bulb, n11=150.0, opening=50.0, blade_angle=-7.0)
    np.testing.assert_allclose(eight.as_tuple()[:6], six.as_tuple(), rtol=1e-12)  # the same differences


def test_bad_points_are_refused():
    with pytest.raises(InputError, match="opening must be > 0"):
        eight_coefficients(SyntheticBulb(), n11=150.0, opening=0.0, blade_angle=0.0)
    with pytest.raises(InputError, match="blade_angle must be finite"):
        eight_coefficients(SyntheticBulb(), n11=150.0, opening=50.0, blade_angle=float("nan"))


def test_cli_prints_eight_coefficients_and_needs_the_blade_angle(capsys):
    from hillsim.cli import main

    assert main(["linearize", str(BULB_DIR / "nets.json"), "--n11", "150", "--opening", "50",
                 "--blade-angle", "-7"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["coefficients"]) == {"ex", "ey", "eh", "eqx", "eqy", "eqh", "ephi", "eqphi"}
    assert out["coefficient_units"]["ephi"] == "1/deg" and out["warnings"] == []
    assert main(["linearize", "synthetic-bulb", "--n11", "150", "--opening", "50"]) == 2
    assert "--blade-angle" in capsys.readouterr().err
    assert main(["linearize", str(BULB_DIR / "nets.json"), "--n11", "400", "--opening", "50",
                 "--blade-angle", "-7"]) == 0
    assert "outside the nets' training range" in capsys.readouterr().err
