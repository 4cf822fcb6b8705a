"""Double-regulated units in the simulator: three-input characteristics, blade servo and combinator, draft tube."""

import dataclasses

import numpy as np
import pytest

from hillchart.nets.hill_nets import HillNets
from data_synthetic import PLANT_BULB, PLANT_HLA339
from hillchart.errors import InputError
from hillchart.fccm.double_regulated import DoubleRegulatedNets, net3_point, packed_net3
from hillchart.fccm.net import FCCMWeights
from hillchart.synthetic.bulb import SyntheticBulb, unit_point
from simulate.components.turbine.double_regulated import FixedBladeBulb
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation

EXACT = {"turbine.characteristics": "synthetic-bulb"}


def _efficiency(result, i=0):
    """Hydraulic efficiency P / (rho g Q H) of row ``i`` of a run."""
    return result.power_mw[i] * 1e6 / (1000.0 * 9.81 * result.flow_m3_s[i] * result.head_m[i])


# --- the compiled point functions against their numpy originals ---------------------------------------------------
def test_bulb_point_kernel_equals_the_numpy_model_and_its_derivatives():
    bulb = SyntheticBulb()
    p = bulb.point_parameters()
    rng = np.random.default_rng(0)
    for n11, gv, phi in zip(rng.uniform(60, 300, 20), rng.uniform(36, 78, 20), rng.uniform(-18, 16, 20)):
        q, dq, m, dm = unit_point(p, n11, gv, phi)
        # the same formulas on scalars: a few ulp of the terms (torque ~1e3 N*m)
        assert q == pytest.approx(float(bulb.q11(n11, gv, phi)), rel=1e-12, abs=1e-14)
        assert m == pytest.approx(float(bulb.m11(n11, gv, phi)), rel=1e-12, abs=1e-9)
        h = 1e-4  # central difference: truncation ~h^2 f''' and rounding ~eps f / h, both < 1e-7 relative here
        dq_fd = (bulb.q11(n11 + h, gv, phi) - bulb.q11(n11 - h, gv, phi)) / (2 * h)
        dm_fd = (bulb.m11(n11 + h, gv, phi) - bulb.m11(n11 - h, gv, phi)) / (2 * h)
        assert dq == pytest.approx(float(dq_fd), rel=1e-6, abs=1e-10)
        assert dm == pytest.approx(float(dm_fd), rel=1e-6, abs=1e-6)
    # a wrong derivative (the derivative of cm dropped) would be off by O(1): the check can fail
    assert abs(unit_point(p, 150.0, 60.0, 0.0)[1]) > 1e-4


def test_three_input_net_point_equals_predict_and_its_gradient():
    rng = np.random.default_rng(1)
    w = FCCMWeights(inputs=["n11", "opening", "blade_angle"], outputs=["q11"], x_min=[50, 30, -20],
                    x_max=[250, 80, 20], y_min=[0.1], y_max=[3.0], W1=rng.normal(size=(6, 3)), b1=rng.normal(size=6),
                    W2=rng.normal(size=(1, 6)), b2=[0.2])
    packed = packed_net3(w)
    X = np.column_stack([rng.uniform(50, 250, 30), rng.uniform(30, 80, 30), rng.uniform(-20, 20, 30)])
    y, jac = w.predict(X)[:, 0], w.predict_grad(X)[:, 0, 0]
    for k in range(len(X)):
        v, d = net3_point(packed, *X[k])
        assert v == pytest.approx(y[k], rel=1e-13, abs=1e-13)  # same sums in another order: a few ulp
        assert d == pytest.approx(jac[k], rel=1e-12, abs=1e-15)


# --- steady state on the cam ----------------------------------------------------------------------------------------
def test_steady_state_sits_on_the_cam_with_the_exact_efficiency():
    plant = load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 1.0, "scenario.event_time_s": 0.99})
    r = run_simulation(plant)
    bulb = SyntheticBulb()
    phi0 = r.signals["blade_angle_deg"][0]
    # the blades start where the combinator asks (the same slice of the cam): round-off of the stroke <-> angle map
    assert phi0 == pytest.approx(r.signals["blade_angle_cam_deg"][0], abs=1e-12)
    # ... and stay there while nothing happens (no drift of the blade servo at the steady state)
    np.testing.assert_allclose(r.signals["blade_angle_deg"][r.time_s < 0.985], phi0, atol=1e-9)
    n11 = r.speed_rpm[0] * 3.8 / np.sqrt(r.head_m[0])
    a0 = r.opening_chart[0] + 35.0
    truth = float(bulb.unit_efficiency(n11, a0, phi0))
    # the run's efficiency P / (rho g Q H) is the exact bulb's at that point: 1e-9 (steady residuals are 1e-9)
    assert _efficiency(r) == pytest.approx(truth, rel=1e-9)
    # the cam is the best blade angle: a fine scan finds nothing better than the table's interpolation error
    # (the efficiency is flat at its optimum; a cam off by 0.5 deg loses ~1e-4)
    scan = bulb.unit_efficiency(n11, a0, np.linspace(-18, 16, 3401))
    assert truth >= scan.max() - 2e-6
    assert truth - float(bulb.unit_efficiency(n11, a0, phi0 + 2.0)) > 1e-4  # the scan would see a wrong cam


def test_steady_state_on_the_nets_cam_gives_the_nets_efficiency():
    plant = load_plant(PLANT_BULB, {"scenario.t_end_s": 0.1, "scenario.event_time_s": 0.09})
    nets = load_characteristics(plant.turbine, plant.base_dir)
    assert isinstance(nets, DoubleRegulatedNets)
    r = run_simulation(plant)
    phi0 = r.signals["blade_angle_deg"][0]
    n11 = r.speed_rpm[0] * 3.8 / np.sqrt(r.head_m[0])
    eta = float(nets.efficiency(n11, r.opening_chart[0] + 35.0, phi0))
    assert _efficiency(r) == pytest.approx(eta, rel=1e-9)  # steady residuals 1e-9
    scan = nets.efficiency(n11, r.opening_chart[0] + 35.0, np.linspace(-18, 16, 3401))
    assert eta >= scan.max() - 2e-6  # on the nets' cam (table interpolation)


# --- degenerate cases that must match today's two-input path --------------------------------------------------------
@pytest.mark.slow
def test_blades_fixed_equals_the_two_input_bulb_at_that_angle():
    over = {**EXACT, "combinator.relation": "off", "combinator.fixed_angle_deg": -6.0, "scenario.t_end_s": 12.0}
    plant = dataclasses.replace(load_plant(PLANT_BULB, over), draft_tube=None)
    three = run_simulation(plant)
    two_plant = dataclasses.replace(plant, combinator=None, blade_servo=None)
    two = run_simulation(two_plant, FixedBladeBulb(SyntheticBulb(), blade_angle_deg=-6.0,
                                                   opening_at_zero_stroke=35.0))
    assert three.meta["compiled"] and two.meta["compiled"]
    # the same equations; the blade angle passes through the stroke map -6 = -18 + y 2 (a few ulp) - 1e-9 relative
    for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
        np.testing.assert_allclose(getattr(three, name), getattr(two, name), rtol=1e-9, atol=1e-9)
    assert np.all(three.signals["blade_angle_deg"] == pytest.approx(-6.0, abs=1e-12))


def _frozen_blade_nets(hill_nets) -> DoubleRegulatedNets:
    """Two-input hill nets as three-input nets whose blade-angle weights are zero."""
    def block(w, name):
        W1 = np.column_stack([np.asarray(w.W1), np.zeros(w.hidden)])
        return FCCMWeights(inputs=["n11", "opening", "blade_angle"], outputs=[name],
                           x_min=[*w.x_min, -20.0], x_max=[*w.x_max, 20.0], y_min=[w.y_min], y_max=[w.y_max],
                           W1=W1, b1=w.b1, W2=[w.W2], b2=[w.b2])
    return DoubleRegulatedNets(block(hill_nets.flow, "q11"), block(hill_nets.torque, "m11"), opening_unit="mm")


@pytest.mark.slow
def test_blade_angle_frozen_in_the_nets_equals_todays_two_input_result():
    plant = load_plant(PLANT_HLA339, {"scenario.t_end_s": 8.0})
    shipped = load_characteristics(plant.turbine, plant.base_dir)
    # the two nets alone (the shipped file also hands over to its physical model below the lowest line, which
    # three-input nets do not carry)
    two_nets = HillNets(flow=shipped.flow, torque=shipped.torque, opening_unit=shipped.opening_unit)
    ref = run_simulation(plant, two_nets)
    from simulate.components.control.blade_servo import BladeServoConfig, CombinatorConfig

    three_plant = dataclasses.replace(
        # a user cam at 0 deg (the frozen nets' efficiency is flat in the blade angle: no cam of best efficiency)
        plant, combinator=CombinatorConfig(relation="table", table_openings=(0.0, 34.0), table_heads_m=(100.0, 200.0),
                                           table_angles_deg=((0.0, 0.0), (0.0, 0.0))),
        blade_servo=BladeServoConfig(servo_time_s=1.0, closing_time_s=30.0, opening_time_s=30.0,
                                     angle_min_deg=-20.0, angle_max_deg=20.0, mode="law", law_start_s=1.0,
                                     law_target_deg=20.0))
    alt = run_simulation(three_plant, _frozen_blade_nets(two_nets))
    assert np.ptp(alt.signals["blade_angle_deg"]) > 5.0  # the blades move (by their law); the nets ignore them
    # the same sums with a zero term added (a few ulp): 1e-9 relative
    for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
        np.testing.assert_allclose(getattr(alt, name), getattr(ref, name), rtol=1e-9, atol=1e-9)


# --- the blade servo follows the cam, is held, or follows a law -----------------------------------------------------
def test_blade_servo_lags_the_cam_at_its_rate_limit_and_can_be_held():
    plant = load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 6.0})
    r = run_simulation(plant)
    t, phi, cam = r.time_s, r.signals["blade_angle_deg"], r.signals["blade_angle_cam_deg"]
    rate = np.diff(phi) / np.diff(t)
    # closing at most a full stroke (34 deg) per closing_time_s = 30 s
    assert rate.min() >= -34.0 / 30.0 * (1 + 1e-9)
    assert rate.min() < -0.99 * 34.0 / 30.0  # ... and the limit is reached (the vanes close faster)
    assert np.max(phi - cam) > 2.0  # the blades lag the cam by degrees
    held = run_simulation(load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 6.0, "blade_servo.mode": "held"}))
    assert np.ptp(held.signals["blade_angle_deg"]) < 1e-12
    assert held.summary()["max_speed_rise"] != pytest.approx(r.summary()["max_speed_rise"], abs=1e-3)
    law = run_simulation(load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 6.0, "blade_servo.mode": "law",
                                                 "blade_servo.law_start_s": 1.0}))
    phi_law = law.signals["blade_angle_deg"]
    assert phi_law[law.time_s < 1.0 - 1e-9] == pytest.approx(phi[0], abs=1e-12)  # the law starts at t = 1 s
    # after 1 s the blades close at their rate towards angle_min_deg (first-order lag of 1 s at the start)
    assert phi_law[-1] == pytest.approx(phi[0] - 34.0 / 30.0 * 5.0, abs=1.2)


# --- the draft tube ---------------------------------------------------------------------------------------------------
def test_draft_tube_columns_and_minimum_outlet_pressure():
    plant = load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 8.0})
    r = run_simulation(plant)
    s = r.summary()
    dt_head = r.signals["draft_tube_head_m"]
    # steady: the outlet head is the draft tube's friction loss above the tailwater
    k = plant.draft_tube.friction_coefficient_s2_m5
    assert dt_head[0] == pytest.approx(k * r.flow_m3_s[0] ** 2, rel=1e-9)
    outlet = dt_head + 10.33 + 4.0  # atmospheric head, runner 4 m below the tailwater
    assert s["min_outlet_pressure_head_m"] == pytest.approx(outlet.min(), abs=1e-12)
    # the vanes close: the draft tube pressure falls (reverse water hammer) by metres
    assert dt_head.min() < -3.0
    assert not any("runner outlet" in w for w in s["warnings"])
    warned = run_simulation(load_plant(PLANT_BULB, {**EXACT, "scenario.t_end_s": 8.0,
                                                    "draft_tube.vapour_margin_m": 8.0}))
    assert any("runner outlet" in w and "vapour" in w for w in warned.summary()["warnings"])


def test_rigid_draft_tube_agrees_with_moc_on_a_slow_closure():
    base = {**EXACT, "scenario.t_end_s": 8.0}
    moc = run_simulation(load_plant(PLANT_BULB, base))
    rigid = run_simulation(load_plant(PLANT_BULB, {**base, "draft_tube.model": "rigid"}))
    # a 30 m draft tube (travel 0.03 s) against a closure of seconds: the column is nearly inelastic; the MOC
    # draft tube rings at 4 L / a = 0.12 s, which the rigid one has not: 0.5 m of the 13 m head
    assert rigid.summary()["min_outlet_pressure_head_m"] == pytest.approx(
        moc.summary()["min_outlet_pressure_head_m"], abs=0.5)
    assert rigid.summary()["max_speed_rise"] == pytest.approx(moc.summary()["max_speed_rise"], abs=2e-3)


# --- bad input --------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("over, match", [
    ({"combinator.relation": "wrong"}, r"combinator\.relation must be one of"),
    ({"combinator.relation": "off"}, r"fixed_angle_deg"),
    ({"combinator.relation": "table"}, r"table_openings, table_heads_m and table_angles_deg"),
    ({"combinator.relation": "table", "combinator.table_openings": [40, 60], "combinator.table_heads_m": [10, 14],
      "combinator.table_angles_deg": [[-8, -6, -5]]}, r"2 rows \(one per head\) of 2 finite angles"),
    ({"blade_servo.angle_max_deg": -20.0}, r"blade_servo\.angle_max_deg must be > "),
    ({"blade_servo.mode": "cam"}, r"blade_servo\.mode must be one of"),
    ({"blade_servo.colsing_time_s": 3.0}, r"unknown key blade_servo\.colsing_time_s"),
    ({"draft_tube.model": "lumped"}, r"draft_tube\.model must be one of"),
    ({"draft_tube.segments": []}, r"draft_tube\.segments must be a non-empty"),
    ({"draft_tube.segments": [{"length_m": 30.0}]},
     r"missing required key draft_tube\.segments\.diameter_m \(segment 0\)"),
])
def test_bad_double_regulated_input_names_the_key(over, match):
    with pytest.raises(InputError, match=match):
        load_plant(PLANT_BULB, {**EXACT, **over})


def test_the_fitted_model_cam_needs_nets_that_carry_the_model(tmp_path):
    import json

    from data_synthetic import BULB_DIR

    doc = json.loads((BULB_DIR / "nets.json").read_text())
    del doc["silent_model"]  # nets without the physical model (e.g. trained with --no-extension)
    (tmp_path / "nets.json").write_text(json.dumps(doc))
    over = {"combinator.relation": "model", "scenario.t_end_s": 0.1, "scenario.event_time_s": 0.05,
            "turbine.characteristics": str(tmp_path / "nets.json")}
    with pytest.raises(InputError, match=r"relation = \"model\" takes the cam from the physical model fitted.*"
                                         r"has none: use \"cam\" or \"table\""):
        run_simulation(load_plant(PLANT_BULB, over))
    # with it (the shipped nets), the model's cam: the run starts on it
    r = run_simulation(load_plant(PLANT_BULB, {**over, "turbine.characteristics": "bulb/nets.json"}))
    assert r.signals["blade_angle_cam_deg"][0] == pytest.approx(r.signals["blade_angle_deg"][0], rel=1e-12)


def test_three_input_characteristics_need_a_combinator_and_two_input_ones_refuse_it():
    plant = load_plant(PLANT_BULB, EXACT)
    with pytest.raises(InputError, match=r"needs a \[combinator\] section"):
        run_simulation(dataclasses.replace(plant, combinator=None, blade_servo=None))
    with pytest.raises(InputError, match=r"\[combinator\] and \[blade_servo\] need three-input characteristics"):
        run_simulation(load_plant(PLANT_BULB, {"turbine.characteristics": "ideal"}))
    with pytest.raises(InputError, match=r"needs a \[blade_servo\] section"):
        run_simulation(dataclasses.replace(plant, blade_servo=None))


def test_a_user_cam_table_drives_the_blades():
    table = {"combinator.relation": "table", "combinator.table_openings": [35.0, 78.0],
             "combinator.table_heads_m": [10.0, 14.0], "combinator.table_angles_deg": [[-12.0, -4.0], [-12.0, -4.0]]}
    r = run_simulation(load_plant(PLANT_BULB, {**EXACT, **table, "scenario.t_end_s": 0.1,
                                               "scenario.event_time_s": 0.09}))
    a0 = r.opening_chart[0]  # from the closed vane: the table's 35 deg is its zero
    assert r.signals["blade_angle_deg"][0] == pytest.approx(-12.0 + 8.0 * a0 / 43.0, abs=1e-9)


# --- the shipped nets against the exact bulb they were trained on ---------------------------------------------------
def test_rejection_with_the_nets_matches_the_exact_bulb():
    over = {"scenario.t_end_s": 15.0}  # the maximum speed comes at ~7 s, the minimum outlet pressure at ~5 s
    nets = run_simulation(load_plant(PLANT_BULB, over)).summary()
    exact = run_simulation(load_plant(PLANT_BULB, {**over, **EXACT})).summary()
    head = exact["initial_head_m"]
    # the guarantee figures: speed within 1 point, max head and min outlet pressure within 2 % of the head
    assert abs(nets["max_speed_rise"] - exact["max_speed_rise"]) < 0.01
    assert abs(nets["max_head_m"] - exact["max_head_m"]) < 0.02 * head
    assert abs(nets["min_outlet_pressure_head_m"] - exact["min_outlet_pressure_head_m"]) < 0.02 * head
    # and the rejection is a real one (the figures move by far more than the bounds)
    assert exact["max_speed_rise"] > 0.3 and exact["max_head_m"] - head > 0.5 * head


# --- the work outside the loop -------------------------------------------------------------------------------------
@pytest.mark.parametrize("over", [{}, EXACT])
def test_steady_kernel_gives_the_views_values_through_one_compiled_call(over):
    from simulate.loop.engine import plant_characteristics

    plant = load_plant(PLANT_BULB, over)
    view = plant_characteristics(plant, load_characteristics(plant.turbine, plant.base_dir))
    kernel, params = view.steady_kernel()
    for n11, a in ((120.0, 5.0), (149.6, 16.0), (200.0, 40.0)):
        out = kernel(params, n11, a)
        # the same compiled kernel at the same cam angle as the view's three_input: equal to rounding
        assert out[0] == pytest.approx(float(view.q11(n11, a)), rel=1e-12, abs=1e-15)
        assert out[3] == pytest.approx(float(view.m11(n11, a)), rel=1e-12, abs=1e-9)
        assert np.isnan(out[1]) and np.isnan(out[5])  # values only: no derivative a caller could mistake
    # a point off the cam's slice (another head) gives another value: the kernel reads the head from N11
    assert abs(kernel(params, 120.0, 16.0)[0] - kernel(params, 200.0, 16.0)[0]) > 1e-3


def test_the_cam_is_computed_once_for_the_same_nets_read_again():
    from simulate.components.turbine import double_regulated as dr
    from simulate.loop.engine import plant_characteristics

    plant = load_plant(PLANT_BULB)
    first = plant_characteristics(plant, load_characteristics(plant.turbine, plant.base_dir))
    again = plant_characteristics(plant, load_characteristics(plant.turbine, plant.base_dir))
    assert again.inner is not first.inner and again.cam is first.cam  # a new object, the same numbers: cached
    nets = load_characteristics(plant.turbine, plant.base_dir)
    w = nets.flow
    changed = DoubleRegulatedNets(flow=dataclasses.replace(w, b2=w.b2 + 0.01), torque=nets.torque)
    other = plant_characteristics(plant, changed)
    assert other.cam is not first.cam  # other numbers: a cam of their own
    assert len(dr._CAMS) == 1  # one plant at a time


@pytest.mark.slow
def test_pressure_loop_reads_the_flow_half_and_the_run_is_unchanged(monkeypatch):
    from simulate.components.turbine.evaluation import compile_characteristics
    from simulate.components.turbine.double_regulated import (DoubleRegulatedTurbine, nets_control_flow,
                                                              nets_control_torque)
    from simulate.components.turbine.boundary import build_pressure_loop
    from simulate.components.turbine.component import BoundaryInputs
    from simulate.loop.generator import loop_source
    from simulate.loop.engine import build_parts, initial_state, plant_characteristics

    # the improved loop (the plant file's Newton reads the whole kernel in its iterations)
    plant = load_plant(PLANT_BULB, {"scenario.t_end_s": 8.0, "solver.pressure_loop": "improved"})
    view = plant_characteristics(plant, load_characteristics(plant.turbine, plant.base_dir))
    cc = compile_characteristics(view)
    assert cc.flow_kernel is nets_control_flow and cc.torque_value is nets_control_torque
    controls = np.array([12.0, 0.4])
    for n11 in (110.0, 150.0, 260.0):
        full, half = cc.kernel(cc.params, n11, controls), nets_control_flow(cc.params, n11, controls)
        # the same net3_point on the same inputs: equal to the last bit on one machine (1e-15 for safety)
        assert half[0] == pytest.approx(full[0], rel=1e-15) and half[1] == pytest.approx(full[1], rel=1e-15)
        assert nets_control_torque(cc.params, n11, controls) == pytest.approx(full[2], rel=1e-15)
    steady = initial_state(plant, view)
    parts, _ = build_parts(plant, steady, 0.01, 1, view)
    unit = {"conduit": parts["penstock"], **{kind: parts[kind] for kind in ("downstream", "control", "shaft")}}
    unit["turbine"] = build_pressure_loop(BoundaryInputs(
        turbine=plant.turbine, solver=plant.solver, characteristics=view, compiled=cc, steady=steady, n_controls=2,
        head_floor_m=1e-4 * plant.turbine.rated_head_m, closed_stroke=1e-6))
    source, _ = loop_source({"upstream": parts["upstream"]}, [unit], cc, "improved", True)
    assert "nets_control_flow as flow_kernel" in source and "q11 = flow_kernel(params, n11, opening)[0]" in source
    assert "nets_control_torque as torque_kernel" in source
    with_half = run_simulation(plant)
    monkeypatch.setattr(DoubleRegulatedTurbine, "numba_control_flow_kernel", lambda self: None)
    monkeypatch.setattr(DoubleRegulatedTurbine, "numba_control_torque_kernel", lambda self: None)
    assert compile_characteristics(view).flow_kernel is None and compile_characteristics(view).torque_value is None
    without = run_simulation(plant)  # the loop reads the full kernel: another generated loop, the same numbers
    assert without.wall_time_s > 0 and with_half.head_m.size == without.head_m.size
    # the same arithmetic in another compiled function: equal to rounding (1e-12 of the head)
    assert np.max(np.abs(with_half.head_m - without.head_m)) < 1e-12 * plant.turbine.rated_head_m
    assert np.max(np.abs(with_half.speed_rpm - without.speed_rpm)) < 1e-12 * plant.turbine.rated_speed_rpm


def test_a_combinator_head_outside_the_plants_heads_is_refused():
    """300 m on the 12 m bulb plant (static head 12.9 m) is refused naming the range; 10 m loads."""
    assert load_plant(PLANT_BULB, {"combinator.head_m": 10.0}).combinator.head_m == 10.0
    # allowed [0.25 x 12, 1.5 x 12.9] = [3, 19.35] m
    with pytest.raises(InputError, match=r"combinator\.head_m = 300\.0 m is outside this plant's heads \(turbine\."
                                         r"rated_head_m = 12\.0 m, penstock\.static_head_m = 12\.9 m\); allowed "
                                         r"\[3, 19\.35\] m .*or leave head_m out"):
        load_plant(PLANT_BULB, {"combinator.head_m": 300.0})


@pytest.mark.parametrize("mode", ["combinator", "held"])
def test_blade_law_keys_outside_law_mode_are_refused_not_ignored(mode):
    """law_start_s / law_target_deg with the blades on the cam (or held) did nothing; with mode = "law" they load."""
    law = {"blade_servo.law_start_s": 1.0, "blade_servo.law_target_deg": -10.0}
    servo = load_plant(PLANT_BULB, {**law, "blade_servo.mode": "law"}).blade_servo
    assert (servo.law_start_s, servo.law_target_deg) == (1.0, -10.0)
    with pytest.raises(InputError, match=rf"blade_servo\.law_start_s = 1\.0, blade_servo\.law_target_deg = -10\.0: "
                                         rf"the blade law's keys go with mode = \"law\"; with mode = '{mode}' .* "
                                         rf"ignored: set mode = \"law\" or remove the key"):
        load_plant(PLANT_BULB, {**law, "blade_servo.mode": mode})
