"""Three-input nets blended into the fitted bulb model below the table's smallest guide-vane angle."""

import json

import numpy as np
import pytest

from data_synthetic import BULB_DIR
from hillchart.errors import InputError
from hillchart.extension.bulb_model import unit_values
from hillchart.fccm.double_regulated import (BulbSilentModel, DoubleRegulatedNets, blended_point, blended_value,
                                             load_double_regulated_nets, packed_net3)
from hillchart.synthetic.bulb import SyntheticBulb

LOW, HIGH = 37.5, 40.0  # the model alone at or below 37.5 deg, the nets alone from 40 deg


@pytest.fixture(scope="module")
def nets():
    """The shipped bulb nets with the exact bulb as their silent model (a model that differs from the nets)."""
    plain = load_double_regulated_nets(BULB_DIR / "nets.json")
    model = BulbSilentModel(SyntheticBulb().point_parameters(), (LOW, HIGH))
    return plain, DoubleRegulatedNets(plain.flow, plain.torque, training=plain.training, silent_model=model)


def test_the_model_answers_below_the_blend_and_the_nets_above(nets):
    plain, blended = nets
    n11, blade = np.array([120.0, 180.0, 260.0]), np.array([-10.0, 0.0, 12.0])
    params = SyntheticBulb().point_parameters()
    for gv in (35.0, 36.0, LOW):
        q, m = unit_values(params, n11, np.full(3, gv), blade)
        np.testing.assert_array_equal(blended.q11(n11, gv, blade), q)
        np.testing.assert_array_equal(blended.m11(n11, gv, blade), m)
    for gv in (HIGH, 55.0):
        np.testing.assert_allclose(blended.q11(n11, gv, blade), plain.q11(n11, gv, blade), rtol=1e-12)
        np.testing.assert_allclose(blended.m11(n11, gv, blade), plain.m11(n11, gv, blade), rtol=1e-12)
    # at the closed vane the flow is the model's: zero to 1e-9 of full flow (a nets' misfit would be -0.3 %)
    assert np.all(np.abs(blended.q11(n11, 35.0, blade)) < 1e-9)
    assert np.all(blended.q11(n11, 35.0, blade) >= 0.0)


def test_the_blend_is_c1_in_the_opening(nets):
    _, blended = nets
    n11, blade = 170.0, -4.0
    for edge in (LOW, HIGH):
        for f in (blended.q11, blended.m11):
            h = 1e-6
            left = (f(n11, edge, blade) - f(n11, edge - h, blade)) / h
            right = (f(n11, edge + h, blade) - f(n11, edge, blade)) / h
            # continuous slope: the one-sided differences agree to the O(h) of a forward difference
            assert right == pytest.approx(left, rel=1e-3, abs=1e-3 * abs(float(f(n11, HIGH, blade))))


def test_gradients_in_the_blend_are_those_of_the_values(nets):
    _, blended = nets
    n11, gv, blade = np.array([150.0, 210.0]), np.array([38.3, 39.1]), np.array([-6.0, 8.0])
    for value, grad in ((blended.q11, blended.q11_grad), (blended.m11, blended.m11_grad)):
        g = grad(n11, gv, blade)
        for j, step in enumerate((np.array([1e-4, 0, 0]), np.array([0, 1e-4, 0]), np.array([0, 0, 1e-4]))):
            fd = (value(n11 + step[0], gv + step[1], blade + step[2])
                  - value(n11 - step[0], gv - step[1], blade - step[2])) / 2e-4
            # central differences of step 1e-4: truncation ~1e-8 of the value's scale
            np.testing.assert_allclose(g[j], fd, rtol=1e-5, atol=1e-6 * np.abs(value(n11, gv, blade)).max())


def test_the_compiled_kernels_are_the_numpy_values(nets):
    _, blended = nets
    flow, torque, blend = packed_net3(blended.flow), packed_net3(blended.torque), blended.blend_packed()
    for gv in (35.5, 38.7, 44.0):
        q, dq, m, dm = blended_point(flow, torque, blend, 160.0, gv, 3.0)
        assert q == pytest.approx(float(blended.q11(160.0, gv, 3.0)), rel=1e-13)
        assert m == pytest.approx(float(blended.m11(160.0, gv, 3.0)), rel=1e-13)
        assert dq == pytest.approx(float(blended.q11_grad(160.0, gv, 3.0)[0]), rel=1e-12)
        # the value kernels the pressure loop reads: the same arithmetic
        assert blended_value(flow, blend, 160.0, gv, 3.0, 0) == q
        assert blended_value(torque, blend, 160.0, gv, 3.0, 1) == m


def test_json_round_trip_and_bad_blocks(nets, tmp_path):
    _, blended = nets
    path = blended.save(tmp_path / "nets.json")
    again = load_double_regulated_nets(path)
    np.testing.assert_array_equal(again.blend_packed(), blended.blend_packed())
    doc = json.loads(path.read_text())
    doc["silent_model"]["blend_openings"] = [40.0, 37.5]
    with pytest.raises(InputError, match=r"silent_model.blend_openings must be two finite angles low < high"):
        DoubleRegulatedNets.from_dict(doc)
    doc["silent_model"]["blend_openings"] = [37.5, 40.0]
    doc["silent_model"]["kind"] = "francis-1d"
    with pytest.raises(InputError, match=r"silent_model.kind must be 'bulb-1d', got 'francis-1d'"):
        DoubleRegulatedNets.from_dict(doc)
    doc["silent_model"]["kind"] = "bulb-1d"
    del doc["silent_model"]["parameters"]["k_swirl"]
    with pytest.raises(InputError, match=r"silent_model.parameters must have exactly the keys"):
        DoubleRegulatedNets.from_dict(doc)


def test_residual_nets_add_to_the_model_above_the_blend(nets, tmp_path):
    """Nets of the residual (``silent_model.residual``): model + w nets, the model alone below the blend."""
    plain, _ = nets
    model = BulbSilentModel(SyntheticBulb().point_parameters(), (LOW, HIGH), residual=True)
    residual = DoubleRegulatedNets(plain.flow, plain.torque, training=plain.training, silent_model=model)
    params = SyntheticBulb().point_parameters()
    n11, blade = np.array([120.0, 180.0]), np.array([-10.0, 12.0])
    for gv, w in ((36.0, 0.0), (55.0, 1.0)):
        q, m = unit_values(params, n11, np.full(2, gv), blade)
        np.testing.assert_allclose(residual.q11(n11, gv, blade), q + w * plain.q11(n11, gv, blade), rtol=1e-13)
        np.testing.assert_allclose(residual.m11(n11, gv, blade), m + w * plain.m11(n11, gv, blade), rtol=1e-13)
    flow, torque, blend = packed_net3(residual.flow), packed_net3(residual.torque), residual.blend_packed()
    q, dq, m, dm = blended_point(flow, torque, blend, 160.0, 50.0, 3.0)
    assert blended_value(flow, blend, 160.0, 50.0, 3.0, 0) == q
    assert blended_value(torque, blend, 160.0, 50.0, 3.0, 1) == m
    g = residual.q11_grad(160.0, 50.0, 3.0)
    fd = (residual.q11(160.0, 50.0 + 1e-4, 3.0) - residual.q11(160.0, 50.0 - 1e-4, 3.0)) / 2e-4
    assert float(g[1]) == pytest.approx(float(fd), rel=1e-5)  # the model's part is in the gradient too
    again = load_double_regulated_nets(residual.save(tmp_path / "nets.json"))
    assert again.silent_model.residual and float(again.m11(160.0, 50.0, 3.0)) == m
    doc = json.loads((tmp_path / "nets.json").read_text())
    doc["silent_model"]["residual"] = "yes"
    with pytest.raises(InputError, match=r"silent_model.residual must be true or false, got 'yes'"):
        DoubleRegulatedNets.from_dict(doc)
