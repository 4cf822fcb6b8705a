"""Four-quadrant characteristics in the simulator: the compiled curves against their Python definitions, the point
the boundary solves against the Suter transform's inverse and the exact machine, the steady state in turbine and
pump mode, and the refusals."""

import math
from pathlib import Path

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.four_quadrant.nets import load_suter_nets
from hillchart.synthetic.pump_turbine import SyntheticPumpTurbine
from simulate.components.turbine.four_quadrant import (SUTER_NETS, SYNTHETIC_PUMP_TURBINE, SuterCharacteristics,
                                                       rated_bases)
from simulate.components.turbine.suter_kernels import INVALID_POINT, NOT_BRACKETED, solve_shifted_flow, suter_point
from simulate.config import load_plant
from simulate.loop.prepare import initial_state

ROOT = Path(__file__).resolve().parents[3]
NETS = ROOT / "data_synthetic" / "pump_turbine" / "nets.json"
PLANT = ROOT / "data_synthetic" / "plant_pump_turbine.toml"


@pytest.fixture(scope="module")
def nets_chars():
    return SUTER_NETS.read({}, NETS)


@pytest.fixture(scope="module")
def exact_chars():
    return SYNTHETIC_PUMP_TURBINE.load(None)


def test_the_compiled_nets_are_the_nets(nets_chars):
    """The kernel's WH, WM are FCCMWeights.predict's to rounding (1e-12 of values of order 1; the sums are the same
    terms in another order); a point of another opening differs by far more."""
    nets = load_suter_nets(NETS)
    x = np.linspace(0.0, 2 * math.pi, 37)
    for y in (0.3, 0.7, 1.0):
        wh, wm = nets.curves(x, np.full_like(x, y))
        kh, km = nets_chars.curve_values(x, y)
        assert np.max(np.abs(kh - wh)) < 1e-12 and np.max(np.abs(km - wm)) < 1e-12
    kh, _ = nets_chars.curve_values(x, 0.5)
    assert np.max(np.abs(kh - nets.curves(x, np.full_like(x, 0.7))[0])) > 1e-2


def test_the_boundary_point_is_the_inverse_transform_of_the_nets(nets_chars):
    """At the improved transform (k2 = 0.5) the point of a shifted flow w has h and q with x = pi + atan2(q + k2
    sqrt(h), v): the nets at that x give back h and m through inverse_suter_transform (1e-12 relative: rounding),
    and SuterNets.head_torque (its own bisection on h to 1e-12, the largest root) the same h to 1e-9 where h(v, q)
    has one root. In the reverse-pump zone (v = 1.1, q = -0.54) it has two, because x moves with h: the point of
    w = -0.4 is h = 0.081, head_torque's the other, 0.117, and both satisfy the transform: walking w (one point
    per w) is what keeps the boundary single-valued."""
    from hillchart.four_quadrant.suter import inverse_suter_transform, suter_angle

    nets = load_suter_nets(NETS)
    p = nets_chars.curves
    for w, v, y, unique in ((1.2, 1.0, 0.7, True), (-0.4, 1.1, 0.5, False), (-0.8, -1.0, 0.9, True),
                            (0.3, 0.0, 0.7, True)):
        q, h, m, status = suter_point(*p, w, v, y)
        assert status == 0
        x = suter_angle(v, q, h, constants=nets.constants)
        assert float(x) == pytest.approx(math.pi + math.atan2(w, v), abs=1e-12)
        wh, wm = nets.curves(np.atleast_1d(x), np.atleast_1d(y))
        h_back, m_back = inverse_suter_transform(wh, wm, v, q, y, constants=nets.constants)
        assert float(h_back[0]) == pytest.approx(h, rel=1e-12) and float(m_back[0]) == pytest.approx(m, rel=1e-12)
        h_ref, m_ref = nets.head_torque(v, q, y)
        if unique:
            assert float(h_ref) == pytest.approx(h, rel=1e-9) and float(m_ref) == pytest.approx(m, rel=1e-9)
            # the check can fail: the point of a 1 % different flow is another head
            assert float(nets.head_torque(v, 1.01 * q, y)[0]) != pytest.approx(h, rel=1e-4)
        else:
            assert float(h_ref) > 1.4 * h  # the other root (measured 0.1165 against 0.0809)


def test_the_tabulated_exact_machine_keeps_to_the_machine(exact_chars):
    """The exact pump-turbine as a 0.5 deg x 0.25 mm table: at unit head and rated N11 the flow it gives makes the
    machine's own head 1 m to 1e-4 (measured 3.6e-5 at 10 mm, 1e-5 from 16 mm: the bilinear table's error) in
    turbine and pump rotation, and its torque the machine's to 1e-4 of the rated torque."""
    machine = SyntheticPumpTurbine()
    r = exact_chars.rated
    for n11 in (r["n11_rpm"], -r["n11_rpm"]):
        for a in (10.0, 20.0, 28.0):
            q11, m11 = float(exact_chars.q11(n11, a)), float(exact_chars.m11(n11, a))
            assert np.sign(q11) == np.sign(n11)  # turbine flow in turbine rotation, pump flow in pump rotation
            head, torque = machine.head_torque(n11, q11, a)
            assert abs(float(head) - 1.0) < 1e-4
            assert abs(float(torque) - m11) < 1e-4 * r["m11_nm"]
    head, _ = machine.head_torque(r["n11_rpm"], 1.01 * float(exact_chars.q11(r["n11_rpm"], 20.0)), 20.0)
    assert abs(float(head) - 1.0) > 1e-3  # a 1 % wrong flow is a wrong head


def test_the_step_solves_through_zero_speed_and_reverse_flow(exact_chars, nets_chars):
    """At v = 0 the plain curves give h = WH(x) q^2 with x = 3 pi/2 (q > 0) or pi/2 (q < 0): the step's root on
    h = c + b q is the quadratic's (1e-12); so it is for a negative speed with reverse flow (pump brake), checked by
    the residual of the relation (1e-12)."""
    p = exact_chars.curves
    wh_pos = exact_chars.curve_values(1.5 * math.pi, 0.7)[0]
    c, b = 0.8, -0.3
    w, status, _ = solve_shifted_flow(*p, 0.0, 0.7, c, b, 0.5, 1e-14, 200)
    q_quadratic = (b + math.sqrt(b * b + 4 * wh_pos * c)) / (2 * wh_pos)
    assert status == 0 and w == pytest.approx(q_quadratic, rel=1e-12)
    for v, w0 in ((-0.5, 0.2), (0.3, -0.6), (1.0, 1.0)):
        w, status, _ = solve_shifted_flow(*p, v, 0.7, c, b, w0, 1e-14, 200)
        q, h, m, st = suter_point(*p, w, v, 0.7)
        assert status == 0 and st == 0 and abs(h - (c + b * q)) < 1e-12
    # no root: the improved transform's heads are >= 0, a relation h = -1 meets none, and the guard stops the walk
    _, status, _ = solve_shifted_flow(*nets_chars.curves, 1.0, 0.7, -1.0, 0.0, 1.0, 1e-14, 200)
    assert status in (NOT_BRACKETED, INVALID_POINT)


def test_steady_state_in_turbine_and_pump_mode():
    """The verified steady state (residuals < 1e-9) of the example plant: turbine mode at +n_r with Q > 0 and
    P > 0; pump mode at -n_r with Q < 0, torque > 0 and P < 0 (turbine-positive signs)."""
    turbine = initial_state(load_plant(PLANT))
    assert turbine.speed_rpm == pytest.approx(638.18) and turbine.flow_m3_s > 0 and turbine.power_mw > 0
    pump = initial_state(load_plant(PLANT, {"turbine.operating_mode": "pump", "scenario.initial_opening": 0.9,
                                            "penstock.static_head_m": 280.0}))
    assert pump.speed_rpm == pytest.approx(-638.18) and pump.flow_m3_s < 0 and pump.torque_nm > 0
    assert pump.power_mw < 0 and pump.head_m > 280.0  # the pump lifts against the static head plus the loss
    assert max(abs(v) for v in pump.residuals.values()) < 1e-9


def test_pump_mode_needs_four_quadrant_characteristics():
    plant = ROOT / "data_synthetic" / "plant_hla339.toml"
    with pytest.raises(InputError, match=r"turbine.operating_mode = 'pump' needs characteristics over all four "
                                         r"quadrants \(the kinds 'suter-nets', 'suter-curves', "
                                         r"'synthetic-pump-turbine'\)"):
        initial_state(load_plant(plant, {"turbine.operating_mode": "pump"}))


def test_rated_values_that_disagree_with_the_characteristics_are_refused(nets_chars):
    plant = load_plant(PLANT)
    assert rated_bases(nets_chars, plant.turbine)[2] == pytest.approx(638.18, rel=1e-4)
    off = load_plant(PLANT, {"turbine.rated_speed_rpm": 660.0})
    with pytest.raises(InputError, match=r"turbine.rated_speed_rpm: .* is 638\.1\d+; the plant gives 660, more than "
                                         r"1 % off"):
        rated_bases(nets_chars, off.turbine)


def test_bad_curves_are_refused():
    with pytest.raises(InputError, match=r"rated.q11_m3_s must be a number > 0"):
        SuterCharacteristics.from_table(np.ones(16), np.ones(16), rated={"n11_rpm": 1.0, "q11_m3_s": -1.0,
                                                                        "m11_nm": 1.0}, opening_max=1.0, name="t")
    with pytest.raises(InputError, match=r"openings must ascend evenly"):
        SuterCharacteristics.from_table(np.ones((3, 16)), np.ones((3, 16)), openings=[0.1, 0.2, 0.4],
                                        rated={"n11_rpm": 1.0, "q11_m3_s": 1.0, "m11_nm": 1.0}, opening_max=1.0,
                                        name="t")
