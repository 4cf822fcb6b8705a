"""The IEC 60193 model -> prototype efficiency step-up ([turbine.step_up]): the formula against hand-computed
values, the config's validation, the stepped-up characteristics through every command's resolver, and the error
that names the largest reachable power."""

import json
import math

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.components.turbine.step_up import (StepUpConfig, best_efficiency_point, iec60193_step_up,
                                                 reynolds_number, scale_torque)
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import initial_state, run_simulation

STEP_UP = {"turbine.step_up": {"method": "iec60193"}}


@pytest.fixture(scope="module")
def model_nets():
    plant = load_plant(PLANT_HLA339)
    return load_characteristics(plant.turbine, plant.base_dir)


def test_formula_against_hand_computed_values():
    # eta 0.92, Re_M = Re_ref = 7e6, Re_P = 7e8: delta_ref = 0.08 / (1 + 0.3/0.7) = 0.056;
    # (7e6/7e8)^0.16 = 10^-0.32 = 0.4786301; Delta_eta = 0.056 * 0.5213699 = 0.02919672 (by hand, 7 digits)
    assert iec60193_step_up(0.92, 7.0e6, 7.0e8) == pytest.approx(0.02919672, abs=1e-8)
    # a model at a tenth of Re_ref: (10)^0.16 = 1.4454398; delta_ref = 0.08 / (1.4454398 + 0.4285714) = 0.0426891;
    # Delta_eta = 0.0426892 * (1.4454398 - 0.4786301) = 0.0412723
    assert iec60193_step_up(0.92, 7.0e5, 7.0e8) == pytest.approx(0.0412723, abs=2e-7)  # 7-digit hand arithmetic
    # V_ref = 1 (every loss scalable): delta_ref = 1 - eta, Delta_eta = 0.08 * 0.5213699
    assert iec60193_step_up(0.92, 7.0e6, 7.0e8, scalable_loss_share=1.0) == pytest.approx(0.04170959, abs=1e-8)
    assert iec60193_step_up(0.92, 7.0e6, 7.0e6) == 0.0  # the same Reynolds number: no step-up
    assert iec60193_step_up(0.92, 7.0e8, 7.0e6) < 0  # a prototype smaller than its model steps down
    # Re = D u / nu, u = pi D n / 60: 0.35 m at 1000 r/min in water at 20 C: 0.35 * 18.3260 / 1e-6
    assert float(reynolds_number(0.35, 1000.0, 1.0e-6)) == pytest.approx(6.41409e6, rel=1e-5)


def test_config_validation_names_field_value_and_range():
    assert StepUpConfig() == StepUpConfig.from_toml({"method": "iec60193"})
    with pytest.raises(InputError, match=r"turbine\.step_up\.method must be one of iec60193; got 'iec62097'"):
        StepUpConfig(method="iec62097")
    with pytest.raises(InputError, match=r"turbine\.step_up\.model_diameter_m must be in \(0\.0, 20\.0\], got -0\.35"):
        StepUpConfig(model_diameter_m=-0.35)
    with pytest.raises(InputError, match=r"model_efficiency_reference must be in \[0\.3, 1\.0\), got 92\.0"):
        StepUpConfig(model_efficiency_reference=92.0)  # a percentage instead of a fraction
    with pytest.raises(InputError, match=r"kinematic_viscosity_m2_s must be in \[2e-07, 2e-06\], got 0\.001"):
        StepUpConfig(kinematic_viscosity_m2_s=1e-3)
    with pytest.raises(InputError, match=r"unknown key turbine\.step_up\.model_diametre_m; valid keys of "
                                         r"\[turbine\.step_up\]: method, model_diameter_m"):
        load_plant(PLANT_HLA339, {"turbine.step_up": {"model_diametre_m": 0.4}})
    with pytest.raises(InputError, match=r"turbine\.step_up must be a table"):
        load_plant(PLANT_HLA339, {"turbine.step_up": 3})
    # the plant file: [turbine.step_up] as a table, or --set turbine.step_up=iec60193; a round trip keeps it
    plant = load_plant(PLANT_HLA339, {"turbine.step_up": "iec60193"})
    assert plant.turbine.step_up == StepUpConfig()
    assert plant.with_overrides({"turbine.model_head_m": None}).turbine.step_up == StepUpConfig()
    with pytest.raises(InputError, match=r"turbine\.step_up converts a model test's chart.*\"ideal\""):
        load_characteristics(load_plant(PLANT_HLA339, {**STEP_UP, "turbine.characteristics": "ideal"}).turbine)


def test_step_up_of_three_input_characteristics_is_refused_naming_them():
    """The step-up searched a bulb's (three-input) chart for its best point with two arguments (a TypeError)."""
    from data_synthetic import PLANT_BULB

    for spec in ("bulb/nets.json", "synthetic-bulb"):
        plant = load_plant(PLANT_BULB, {"turbine.step_up": "iec60193", "turbine.characteristics": spec})
        with pytest.raises(InputError, match=rf"turbine\.step_up = {{method = 'iec60193'}} converts a two-input "
                                             rf"\(single-regulated\) model chart; turbine\.characteristics = "
                                             rf"'{spec}' has a blade angle \(three inputs"):
            load_characteristics(plant.turbine, plant.base_dir)
    # beside it, the same bulb plant without the step-up loads its three-input nets
    plant = load_plant(PLANT_BULB)
    from simulate.components.turbine.double_regulated import is_three_input

    assert is_three_input(load_characteristics(plant.turbine, plant.base_dir))


def test_stepped_up_nets_raise_torque_by_one_factor_and_keep_flow(model_nets):
    plant = load_plant(PLANT_HLA339, STEP_UP)
    stepped = load_characteristics(plant.turbine, plant.base_dir)
    record = stepped.training["step_up"]
    eta_best, n11_best, _ = best_efficiency_point(model_nets)
    # the record against the formula by hand: the shipped chart's best point, a 0.35 m model at 30 m, the
    # prototype D1 4.5 m at H_r 176 m, both at N11_opt
    re_m = math.pi * 0.35 ** 2 * n11_best * math.sqrt(30.0) / 0.35 / 60 / 1e-6
    re_p = math.pi * 4.5 ** 2 * n11_best * math.sqrt(176.0) / 4.5 / 60 / 1e-6
    delta = (1 - eta_best) / ((7e6 / re_m) ** 0.16 + 0.3 / 0.7) * ((7e6 / re_m) ** 0.16 - (7e6 / re_p) ** 0.16)
    assert record["delta_efficiency"] == pytest.approx(delta, rel=1e-12)
    assert 0.01 < delta < 0.05  # a model test of 0.35 m against a 4.5 m prototype: a few points
    assert record["torque_factor"] == pytest.approx((eta_best + delta) / eta_best, rel=1e-14)
    n11, opening = np.meshgrid(np.linspace(40, 100, 7), np.linspace(2, 32, 7))
    # flow unchanged exactly; torque and its gradient scaled by the factor (the output scaling of the net: exact
    # up to rounding, 1e-12 relative covers it)
    assert np.array_equal(stepped.q11(n11, opening), model_nets.q11(n11, opening))
    k = record["torque_factor"]
    np.testing.assert_allclose(stepped.m11(n11, opening), k * model_nets.m11(n11, opening), rtol=1e-12, atol=1e-9)
    for got, want in zip(stepped.m11_grad(n11, opening), model_nets.m11_grad(n11, opening)):
        np.testing.assert_allclose(got, k * want, rtol=1e-12, atol=1e-9)
    # at the best point the efficiency rises by exactly Delta_eta
    assert float(stepped.efficiency(n11_best, _)) - eta_best == pytest.approx(delta, abs=1e-12)
    # every ensemble member gets the same factor (the band is the prototype's too)
    members, model_members = stepped.members(), model_nets.members()
    assert len(members) == len(model_members) > 0
    np.testing.assert_allclose(members[3].m11(n11, opening), k * model_members[3].m11(n11, opening), rtol=1e-12,
                               atol=1e-9)
    # a user's reference efficiency replaces the searched one
    plant = load_plant(PLANT_HLA339, {"turbine.step_up": {"model_efficiency_reference": 0.9}})
    record = load_characteristics(plant.turbine, plant.base_dir).training["step_up"]
    assert record["model_efficiency"] == 0.9 and record["torque_factor"] == pytest.approx(
        1 + record["delta_efficiency"] / 0.9, rel=1e-14)


def test_exact_turbine_steps_up_through_the_wrapper():
    plant = load_plant(PLANT_HLA339, {**STEP_UP, "turbine.characteristics": "synthetic"})
    stepped = load_characteristics(plant.turbine)
    from hillchart.synthetic.francis import SyntheticFrancis

    exact = SyntheticFrancis()
    k = stepped.factor
    assert 1.01 < k < 1.06
    assert float(stepped.m11(65.0, 20.0)) == pytest.approx(k * float(exact.m11(65.0, 20.0)), rel=1e-14)
    assert float(stepped.q11(65.0, 20.0)) == float(exact.q11(65.0, 20.0))
    # its compiled kernel gives the same numbers as its methods (the loop runs compiled, as with the turbine)
    kernel, params = stepped.numba_kernel()
    out = kernel(params, 65.0, 20.0)
    assert out[3] == pytest.approx(float(stepped.m11(65.0, 20.0)), rel=1e-12)
    assert out[5] == pytest.approx(float(stepped.m11_grad(65.0, 20.0)[1]), rel=1e-6)  # complex step vs kernel


def test_step_up_off_or_factor_one_leaves_the_run_unchanged(model_nets):
    plant = load_plant(PLANT_HLA339, {"scenario.t_end_s": 8.0})
    assert plant.turbine.step_up is None
    base = run_simulation(plant, characteristics=model_nets)
    resolved = run_simulation(plant)  # through load_characteristics, no [turbine.step_up]
    unit = run_simulation(plant, characteristics=scale_torque(model_nets, 1.0))  # the scaled-nets path, k = 1
    for other in (resolved, unit):
        for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
            # the same nets (k = 1: y_min and y_max unchanged): the same numbers; 1e-12 relative allows rounding
            np.testing.assert_allclose(getattr(other, name), getattr(base, name), rtol=1e-12, atol=0)
    assert "step_up" not in base.meta and "step_up" not in resolved.meta


def test_steady_state_and_linearization_agree_with_the_step_up(model_nets):
    from simulate.identification.linear_reference import plant_linearization

    model = load_plant(PLANT_HLA339, {"scenario.initial_power_mw": None, "scenario.initial_opening": 0.8})
    prototype = model.with_overrides(STEP_UP)
    s_model, s_proto = initial_state(model), initial_state(prototype)
    k = load_characteristics(prototype.turbine, prototype.base_dir).training["step_up"]["torque_factor"]
    # the same stroke: the same flow and head (Q11 unchanged), the power up by the torque factor
    assert s_proto.head_m == pytest.approx(s_model.head_m, rel=1e-12)
    assert s_proto.power_mw == pytest.approx(k * s_model.power_mw, rel=1e-12)
    lin_model = plant_linearization(model)
    lin_proto = plant_linearization(prototype)
    assert lin_proto.operating_point.power_mw == pytest.approx(s_proto.power_mw, rel=1e-12)
    # the six coefficients are logarithmic derivatives: a constant torque factor leaves them unchanged
    for name in ("ex", "ey", "eh", "eqx", "eqy", "eqh"):
        assert getattr(lin_proto.coefficients, name) == pytest.approx(getattr(lin_model.coefficients, name),
                                                                      rel=1e-9, abs=1e-12)
    # at a power target the prototype needs a smaller stroke and reports the step-up in its summary
    run = run_simulation(load_plant(PLANT_HLA339, {**STEP_UP, "scenario.t_end_s": 4.0}))
    assert run.steady.stroke < initial_state(load_plant(PLANT_HLA339)).stroke
    assert run.summary()["step_up"]["torque_factor"] == pytest.approx(k, rel=1e-14)


def test_unreachable_power_names_the_largest_power_and_the_step_up(model_nets):
    plant = load_plant(PLANT_HLA339, {"scenario.initial_power_mw": 330.0})
    with pytest.raises(InputError) as info:
        initial_state(plant, model_nets)
    text = str(info.value)
    largest = float(text.split("the largest power it gives is ")[1].split(" MW")[0])
    # the largest power against a fine sweep of the stroke (each point a verified steady state at that stroke)
    sweep = max(initial_state(plant.with_overrides({"scenario.initial_power_mw": None,
                                                    "scenario.initial_opening": y}), model_nets).power_mw
                for y in np.linspace(0.5, 1.0, 51))
    assert largest == pytest.approx(sweep, abs=0.1)  # printed to 0.1 MW; the sweep's grid is within that
    assert "scenario.initial_power_mw = 330.0 is outside the power range" in text
    assert '[turbine.step_up] with method = "iec60193"' in text and "--set turbine.step_up=iec60193" in text
    # with the step-up the message says it is already applied, and its largest power is the larger
    with pytest.raises(InputError, match=r"already applied") as info:
        initial_state(plant.with_overrides(STEP_UP))
    stepped = float(str(info.value).split("the largest power it gives is ")[1].split(" MW")[0])
    k = load_characteristics(plant.with_overrides(STEP_UP).turbine, plant.base_dir).training["step_up"][
        "torque_factor"]
    assert stepped == pytest.approx(k * largest, abs=0.15)  # same stroke, power x k; two roundings to 0.1 MW


def test_nets_json_written_by_train_is_not_changed(tmp_path, model_nets):
    """The step-up lives in the plant, not in the nets file: loading never writes."""
    plant = load_plant(PLANT_HLA339, STEP_UP)
    path = plant.base_dir / plant.turbine.characteristics
    before = path.read_bytes()
    load_characteristics(plant.turbine, plant.base_dir)
    assert path.read_bytes() == before
    assert "step_up" not in json.loads(before)["training"]


@pytest.mark.external
def test_sayano_shushenskaya_unit_runs_beyond_the_model_charts_power_with_the_step_up(tmp_path):
    """The real chart (a model test, D1 6.77 m prototype at 194 m): without the step-up 640 MW is refused with the
    largest reachable power named; with it the largest power rises by the torque factor and a power the model chart
    cannot give runs."""
    from hillsim.cli import main
    from tests.external_charts import write_sayano_chart

    folder = write_sayano_chart(tmp_path / "sayano")  # skips when ../shared/external is absent
    nets = tmp_path / "nets.json"
    assert main(["train", str(folder), "--out", str(nets), "--quiet"]) == 0
    unit = {"turbine.characteristics": str(nets), "turbine.rated_head_m": 194.0, "turbine.rated_speed_rpm": 142.86,
            "turbine.runner_diameter_m": 6.77, "turbine.rated_power_mw": 640.0, "turbine.rated_flow_m3_s": 358.0,
            "turbine.opening_max": 58.0, "penstock.static_head_m": 198.0, "generator.inertia_time_s": 8.0,
            "penstock.segments": [{"length_m": 220.0, "diameter_m": 7.5, "wave_speed_m_s": 1100.0,
                                   "darcy_friction": 0.012},
                                  {"length_m": 100.0, "diameter_m": 7.0, "wave_speed_m_s": 1150.0,
                                   "darcy_friction": 0.012}],
            "scenario.initial_power_mw": 640.0, "scenario.t_end_s": 6.0}
    model = load_plant(PLANT_HLA339, unit)
    with pytest.raises(InputError, match=r"turbine\.step_up") as info:
        initial_state(model)
    largest = float(str(info.value).split("the largest power it gives is ")[1].split(" MW")[0])
    assert 590.0 < largest < 640.0  # measured 616.6 MW (the chart's largest opening line is 58 mm)
    at_full_stroke = float(str(info.value).split(", ")[1].split("]")[0])  # "[p(stroke_min), p(stroke_max)] MW"
    if largest - 0.1 > at_full_stroke:  # measured 615.5 at full stroke: the power peaks before it (stroke 0.96)
        inside = initial_state(model.with_overrides({"scenario.initial_power_mw": largest - 0.1}))
        assert inside.stroke < 1.0 and inside.power_mw == pytest.approx(largest - 0.1, rel=1e-9)
    prototype = model.with_overrides(STEP_UP)
    record = load_characteristics(prototype.turbine, prototype.base_dir).training["step_up"]
    # best point N11 about 68 r/min, eta 0.915: Re_M 6.8e6 (0.35 m, 30 m), Re_P 3.3e8 -> Delta_eta about 0.028
    assert 0.02 < record["delta_efficiency"] < 0.035
    try:
        stepped = initial_state(prototype).power_mw  # 640 MW reachable: the acceptance of the rated power
    except InputError as exc:  # measured 635.2 MW: the nets' efficiency at the 58 mm line is 0.81, the chart's 0.84
        stepped = float(str(exc).split("the largest power it gives is ")[1].split(" MW")[0])
        assert stepped == pytest.approx(record["torque_factor"] * largest, abs=0.15)  # two roundings to 0.1 MW
    target = round(largest + 0.5 * (stepped - largest), 1)  # beyond the model chart, within the prototype's
    run = run_simulation(prototype.with_overrides({"scenario.initial_power_mw": target}))
    assert run.success and run.steady.power_mw == pytest.approx(target, rel=1e-9)
    assert run.summary()["step_up"]["delta_efficiency"] == record["delta_efficiency"]
    with pytest.raises(InputError, match=r"is outside the power range"):
        initial_state(model.with_overrides({"scenario.initial_power_mw": target}))
