"""Plant-file loading: strict keys, ranges, overrides, characteristics loader (garbage in -> clear InputError)."""

import math
from importlib import resources

import pytest

from hillchart.characteristics import IdealTurbine
from hillchart.errors import InputError
from simulate.config import (PlantConfig, load_characteristics, load_plant, parse_override, plant_from_dict,
                             to_dict)

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"


@pytest.fixture()
def raw():
    import tomllib
    return tomllib.loads(PLANT_FILE.read_text())


def _error(raw, match):
    with pytest.raises(InputError, match=match):
        plant_from_dict(raw)


def test_shipped_plant_loads_with_hla339_values():
    plant = load_plant(PLANT_FILE)
    t = plant.turbine
    assert (t.rated_head_m, t.rated_power_mw, t.rated_speed_rpm, t.rated_flow_m3_s, t.runner_diameter_m) == \
        (176.0, 225.0, 200.0, 142.5, 4.5)
    # unit speed and flow at the rated point: N11 = 67.8 r/min, Q11 = 0.530 m3/s (HLA339-like)
    assert t.rated_speed_rpm * t.runner_diameter_m / math.sqrt(t.rated_head_m) == pytest.approx(67.84, abs=0.01)
    assert t.rated_flow_m3_s / (t.runner_diameter_m ** 2 * math.sqrt(t.rated_head_m)) == pytest.approx(0.530,
                                                                                                     abs=1e-3)
    # plausible penstock: Tw in 1-2 s, wave speeds 1100-1200 m/s, total length 400-600 m
    tw = plant.penstock.water_time_s(t.rated_flow_m3_s, t.rated_head_m)
    assert 1.0 < tw < 2.0
    assert 400 <= plant.penstock.length_m <= 600
    assert 8.0 <= plant.generator.inertia_time_s <= 10.0
    assert plant.turbine.characteristics == "francis/nets.json"
    assert plant.base_dir == PLANT_FILE.parent


def test_round_trip_through_dict(raw):
    plant = plant_from_dict(raw)
    again = plant_from_dict(to_dict(plant))
    assert again == plant


@pytest.mark.parametrize("section", ["turbine", "penstock", "generator", "governor", "scenario", "solver"])
def test_unknown_key_in_every_section_is_named(raw, section):
    raw[section]["colour"] = 1
    _error(raw, rf"unknown key {section}\.colour; valid keys")


def test_unknown_segment_key_and_missing_segment_key(raw):
    raw["penstock"]["segments"][1]["roughness_mm"] = 0.1
    _error(raw, r"unknown key penstock\.segments\.roughness_mm \(segment 1\)")
    del raw["penstock"]["segments"][1]["roughness_mm"]
    del raw["penstock"]["segments"][0]["darcy_friction"]
    _error(raw, r"missing required key penstock\.segments\.darcy_friction \(segment 0\)")


@pytest.mark.parametrize("section,key", [
    ("turbine", "rated_head_m"), ("turbine", "opening_max"), ("turbine", "characteristics"),
    ("penstock", "model"), ("penstock", "static_head_m"), ("penstock", "reaches"), ("penstock", "segments"),
    ("generator", "inertia_time_s"), ("governor", "closing_time_s"), ("governor", "opening_time_s"),
    ("scenario", "kind"), ("scenario", "t_end_s")])
def test_missing_required_key_is_named(raw, section, key):
    # (governor.kp and servo_time_s are required by the mode and the servo that read them: the message names those,
    # tests/simulate/components/test_parameters.py)
    del raw[section][key]
    _error(raw, rf"missing required key {section}\.{key}")


def test_missing_section_and_unknown_section(raw):
    del raw["generator"]
    _error(raw, r"missing section \[generator\]")
    raw["generator"] = {"inertia_time_s": 9.0}
    raw["tailrace_tunnel"] = {}  # (was [surge_tank], which is now a real section)
    _error(raw, r"unknown section \[tailrace_tunnel\]")


@pytest.mark.parametrize("section,key,value,allowed", [
    ("turbine", "rated_head_m", -176.0, r"\(0\.0, 3000\.0\]"),
    ("turbine", "rated_flow_m3_s", 0, r"\(0\.0"),
    ("turbine", "rated_speed_rpm", "fast", r"must be a number"),
    ("turbine", "rated_power_mw", float("nan"), r"\(0\.0, 2000\.0\]"),
    ("turbine", "runner_diameter_m", True, r"must be a number"),
    ("turbine", "opening_max", -1, r"\(0\.0"),
    ("penstock", "static_head_m", 0.0, r"\(0\.0, 3000\.0\]"),
    ("penstock", "reaches", 2.5, r"integer in \[1, 10000\]"),
    ("penstock", "reaches", 0, r"integer in \[1, 10000\]"),
    ("penstock", "lumped_alpha", -0.4, r"\(0\.0, 10\.0\]"),
    ("penstock", "zdomain_feedback", -1.0, r"\[0\.0, 100\.0\]"),
    ("generator", "inertia_time_s", 0.0, r"\(0\.0, 100\.0\]"),
    ("generator", "self_regulation", -1.0, r"\[0\.0, 20\.0\]"),
    ("governor", "kp", -2.0, r"\[0\.0, 1000\.0\]"),
    ("governor", "ki", "0.4", r"must be a number"),
    ("governor", "kd", -0.1, r"\[0\.0"),
    ("governor", "derivative_filter_s", -0.2, r"\[0\.0, 100\.0\]"),
    ("governor", "permanent_droop", 1.0, r"\[0\.0, 1\.0\)"),
    ("governor", "servo_time_s", 0.0, r"\(0\.0, 100\.0\]"),
    ("governor", "closing_time_s", 0.0, r"\(0\.0, 1000\.0\]"),
    ("governor", "opening_time_s", -5.0, r"\(0\.0"),
    ("governor", "stroke_max", 2.0, r"\(0\.0, 1\.5\]"),
    ("scenario", "t_end_s", -1.0, r"\(0\.0, 100000\.0\]"),
    ("scenario", "event_time_s", 100.0, r"is not before scenario\.t_end_s = 60\.0 s: the run would end before its "
                                        r"event; set scenario\.t_end_s beyond the event \(e\.g\. 200\)"),
    ("scenario", "event_time_s", 60.0, r"is not before scenario\.t_end_s = 60\.0 s"),
    ("scenario", "event_time_s", -1.0, r"\[0\.0, 60\.0\)"),
    ("scenario", "initial_power_mw", -5.0, r"\[0\.0, 3000\.0\]"),
    ("solver", "dt_s", 0.0, r"\(0\.0, 10\.0\]"),
    ("solver", "tolerance", 0.5, r"\(0\.0, 0\.01\]"),
    ("solver", "max_iterations", 0, r"integer in \[1, 100000\]"),
    ("solver", "relaxation", 1.5, r"\(0\.0, 1\.0\]"),
])
def test_out_of_range_value_names_key_value_and_range(raw, section, key, value, allowed):
    raw[section][key] = value
    with pytest.raises(InputError) as info:
        plant_from_dict(raw)
    text = str(info.value)
    assert f"{section}.{key}" in text
    assert repr(value) in text or repr(float(value)) in text
    assert pytest.importorskip("re").search(allowed, text), text


@pytest.mark.parametrize("key,value,allowed", [
    ("length_m", 0.0, r"\(0\.0, 100000\.0\]"), ("diameter_m", -6.0, r"\(0\.0, 30\.0\]"),
    ("wave_speed_m_s", 5000.0, r"\[20\.0, 1600\.0\]"), ("wave_speed_m_s", 1.0, r"\[20\.0, 1600\.0\]"),
    ("darcy_friction", -0.01, r"\[0\.0, 0\.2\]")])
def test_segment_garbage(raw, key, value, allowed):
    raw["penstock"]["segments"][0][key] = value
    with pytest.raises(InputError, match=rf"penstock\.segments\.{key} must be in {allowed}, got {value!r}"):
        plant_from_dict(raw)


def test_a_branch_wave_speed_of_1_m_s_is_refused_naming_the_unit_and_the_plausible_range():
    """A branch at 1 m/s once ran (20 s travel time on a 20 m pipe); 1180 m/s as shipped loads. The floor, 20 m/s,
    is below the slowest pressure wave in water (air-laden water at atmospheric pressure, about 24 m/s)."""
    import tomllib

    path = resources.files("data_synthetic") / "plant_two_units.toml"
    raw = tomllib.loads(path.read_text())
    assert plant_from_dict(raw).units[0].branch[0].wave_speed_m_s == 1180.0
    raw["units"][0]["branch"][0]["wave_speed_m_s"] = 1.0
    with pytest.raises(InputError, match=r"units\.branch\.wave_speed_m_s must be in \[20\.0, 1600\.0\], got 1\.0 "
                                         r"\(m/s\): pressure waves in water conduits travel at about 100 .* to 1500 "
                                         r"m/s.*give the wave speed in m/s \(segment 0.*\(unit 'U1'\)"):
        plant_from_dict(raw)


def test_a_solver_tolerance_below_the_round_off_floor_is_refused_naming_it(raw):
    """1e-300 was silently raised to the boundary's round-off floor; the floor itself and the default load."""
    from simulate.components.turbine.boundary import ROUNDOFF_TOLERANCE
    from simulate.config import TOLERANCE_FLOOR

    assert TOLERANCE_FLOOR == ROUNDOFF_TOLERANCE  # the config's floor is the one the boundary applies
    for value in (1e-10, TOLERANCE_FLOOR):
        raw["solver"]["tolerance"] = value
        assert plant_from_dict(raw).solver.tolerance == value
    raw["solver"]["tolerance"] = 1e-300
    _error(raw, r"solver\.tolerance = 1e-300 is below 1\.421e-14 \(64 machine epsilons\), the round-off floor .* "
                r"set solver\.tolerance in \[1\.421e-14, 0\.01\]")


def test_zero_friction_is_allowed(raw):
    for seg in raw["penstock"]["segments"]:
        seg["darcy_friction"] = 0.0
    assert plant_from_dict(raw).penstock.friction_coefficient_s2_m5 == 0.0


@pytest.mark.parametrize("section,key,value,choices", [
    ("penstock", "model", "elastic", "moc, zdomain, lumped, rigid"),
    ("solver", "pressure_loop", "secant", "improved, traditional, newton"),
    ("scenario", "kind", "black-start", "load-rejection, closure-law")])
def test_bad_choice_lists_the_choices(raw, section, key, value, choices):
    raw[section][key] = value
    with pytest.raises(InputError, match=rf"{section}\.{key} must be one of {choices}.*{value!r}"):
        plant_from_dict(raw)


def test_scenario_rules(raw):
    raw["scenario"]["initial_opening"] = 0.5  # both initial_power_mw and initial_opening
    _error(raw, r"exactly one of scenario\.initial_power_mw or scenario\.initial_opening")
    del raw["scenario"]["initial_opening"]
    raw["scenario"]["closing_time_s"] = 5.0  # not a load-rejection key
    _error(raw, r"scenario\.closing_time_s is not used by scenario\.kind = 'load-rejection'")
    raw["scenario"]["kind"] = "closure-law"
    raw["scenario"]["break_opening"] = 0.3  # break_time_s missing
    _error(raw, r"break_opening and scenario\.break_time_s go together")
    del raw["scenario"]["closing_time_s"], raw["scenario"]["break_opening"]
    _error(raw, r"scenario\.closing_time_s is required for kind 'closure-law'")
    raw["scenario"] = {"kind": "frequency-steps", "t_end_s": 100.0, "speed_steps": [0.04, -0.08],
                       "step_times_s": [10.0]}
    _error(raw, r"step_times_s must have as many entries as scenario\.speed_steps \(2\)")
    raw["scenario"]["step_times_s"] = [40.0, 10.0]
    _error(raw, r"step_times_s must be non-decreasing")
    raw["scenario"]["step_times_s"] = "10"
    _error(raw, r"scenario\.step_times_s must be a list of numbers")
    raw["scenario"] = {"kind": "frequency-steps", "t_end_s": 100.0, "initial_power_mw": 10.0}
    _error(raw, r"scenario\.initial_power_mw is not used by scenario\.kind = 'frequency-steps'")
    raw["scenario"] = {"kind": "load-step", "t_end_s": 50.0, "initial_opening": 0.5, "load_step": 3.0}
    _error(raw, r"scenario\.load_step must be in \[-1\.0, 1\.0\], got 3\.0")


def test_plant_level_rules(raw):
    raw["scenario"] = {"kind": "load-rejection", "t_end_s": 10.0, "initial_opening": 1.2}
    _error(raw, r"scenario\.initial_opening must be in \[governor\.stroke_min, governor\.stroke_max\]")
    raw["scenario"] = {"kind": "load-rejection", "t_end_s": 10.0, "initial_power_mw": 400.0}
    _error(raw, r"scenario\.initial_power_mw must be in \[0, 1\.5 \* turbine\.rated_power_mw\]")
    raw["scenario"]["initial_power_mw"] = 100.0
    raw["governor"]["stroke_min"] = 0.9
    raw["governor"]["stroke_max"] = 0.5
    _error(raw, r"governor\.stroke_min must be < governor\.stroke_max = 0\.5, got 0\.9")
    raw["governor"]["stroke_min"], raw["governor"]["stroke_max"] = 0.0, 1.0
    raw["turbine"]["rated_power_mw"] = 300.0  # efficiency above 1
    _error(raw, r"turbine\.rated_power_mw = 300\.0 gives a rated efficiency .* = 1\.219")


def test_courant_condition_for_moc(raw):
    plant = plant_from_dict(raw)
    raw["solver"]["dt_s"] = 0.05
    bad = plant_from_dict(raw)
    with pytest.raises(InputError, match=r"solver\.dt_s = 0\.05 s does not meet the MOC Courant condition.*"
                                         r"reaches = 8 the step must be .*= 0\.01906"):
        _ = bad.time_step_s
    # other models accept any step; MOC default is the shortest travel time / reaches
    assert plant.time_step_s == pytest.approx((180.0 / 1180.0) / 8, rel=1e-12)
    raw["penstock"]["model"] = "rigid"
    assert plant_from_dict(raw).time_step_s == 0.05


def test_the_step_hillsim_prints_is_accepted_as_solver_dt_s(raw, capsys, tmp_path):
    """The step as hillsim run prints it (6 significant digits: 0.0190678, 1.8e-7 relative off the Courant step) was
    refused (the tolerance was 1e-9 relative); within 1e-5 it is the grid's own step. Beside it, 3e-5 off is refused."""
    from hillsim.cli import main

    exact = (180.0 / 1180.0) / 8
    printed = float(f"{exact:.6g}")
    assert printed == 0.0190678 and abs(printed - exact) / exact == pytest.approx(1.78e-7, rel=0.01)
    raw["solver"]["dt_s"] = printed
    assert plant_from_dict(raw).time_step_s == exact  # the run takes the exact grid step: the same run as without
    raw["solver"]["dt_s"] = exact * (1 + 3e-5)
    with pytest.raises(InputError, match=r"solver\.dt_s = 0\.01906836.* s does not meet the MOC Courant condition: "
                                         r"with penstock\.reaches = 8 the step must be .* = 0\.019067796610169\d* s "
                                         r"\(within a relative 1e-05\)"):
        _ = plant_from_dict(raw).time_step_s
    # the command line: the printed step passes to the same figures as the default step
    argv = ["run", str(PLANT_FILE), "--set", "scenario.t_end_s=2.5", "--no-plot", "--quiet", "--out"]
    assert main(argv + [str(tmp_path / "a")]) == 0
    assert main(argv + [str(tmp_path / "b"), "--set", "solver.dt_s=0.0190678"]) == 0, capsys.readouterr().err
    outputs = capsys.readouterr().out.splitlines()
    assert "131 steps of 0.0190678 s" in outputs[0] and outputs[0].split(";")[0] == outputs[1].split(";")[0]


def test_wave_speed_adjustment_limit(raw):
    from simulate.config import PenstockConfig, PenstockSegment
    from simulate.components.hydraulic.penstock import build_moc_grid
    pen = PenstockConfig(model="moc", static_head_m=100.0, reaches=1, segments=(
        PenstockSegment(length_m=100.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.0),
        PenstockSegment(length_m=140.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.0)))
    with pytest.raises(InputError, match=r"penstock\.reaches = 1: segment 1 .* changed by 40\.0 %.*increase"):
        build_moc_grid(pen, pen.moc_time_step_s)
    grid = build_moc_grid(replace_reaches(pen, 5), replace_reaches(pen, 5).moc_time_step_s)
    assert grid.reaches_per_segment == (5, 7) and grid.max_wave_speed_adjustment == pytest.approx(0.0, abs=1e-12)


def replace_reaches(pen, n):
    from dataclasses import replace
    return replace(pen, reaches=n)


def test_overrides_parse_as_toml_and_switch_kind():
    assert parse_override("scenario.speed_steps=[0.02, -0.02]") == ("scenario.speed_steps", [0.02, -0.02])
    assert parse_override("solver.max_iterations = 7") == ("solver.max_iterations", 7)
    with pytest.raises(InputError, match=r"--set expects section\.key=value, got 'solver\.dt_s'"):
        parse_override("solver.dt_s")
    with pytest.raises(InputError, match=r"--set key must be section\.key"):
        parse_override("dt_s=0.1")
    with pytest.raises(InputError, match=r"is not a TOML value"):
        parse_override("solver.dt_s=[0.1")
    plant = load_plant(PLANT_FILE, {"scenario.kind": "frequency-steps", "scenario.t_end_s": 100.0})
    assert plant.scenario.kind == "frequency-steps" and plant.scenario.initial_power_mw is None
    with pytest.raises(InputError, match=r"unknown key solver\.dtt"):
        load_plant(PLANT_FILE, {"solver.dtt": 0.1})
    with pytest.raises(InputError, match=r"unknown section in override 'solvr\.dt_s'"):
        load_plant(PLANT_FILE, {"solvr.dt_s": 0.1})


def test_unreadable_and_invalid_files(tmp_path):
    with pytest.raises(InputError, match=r"cannot read plant file"):
        load_plant(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[turbine\nrated_head_m = 1")
    with pytest.raises(InputError, match=r"is not valid TOML"):
        load_plant(bad)


def test_ideal_characteristics_from_rated_values():
    plant = load_plant(PLANT_FILE, {"turbine.characteristics": "ideal"})
    ideal = load_characteristics(plant.turbine)
    assert isinstance(ideal, IdealTurbine)
    t = plant.turbine
    # q11_max = Q_r / (D1^2 sqrt(H_r)) at y = 1 and efficiency = P_r / (rho g Q_r H_r)
    assert ideal.q11_max_m3_s == pytest.approx(142.5 / (4.5 ** 2 * math.sqrt(176.0)), rel=1e-14)
    assert ideal.efficiency == pytest.approx(225e6 / (1000 * 9.81 * 142.5 * 176.0), rel=1e-14)
    # at the rated point the ideal turbine gives exactly the rated flow and power
    n11 = t.rated_speed_rpm * t.runner_diameter_m / math.sqrt(t.rated_head_m)
    q = float(ideal.q11(n11, t.opening_max)) * t.runner_diameter_m ** 2 * math.sqrt(t.rated_head_m)
    m = float(ideal.m11(n11, t.opening_max)) * t.runner_diameter_m ** 3 * t.rated_head_m
    assert q == pytest.approx(142.5, rel=1e-12)
    assert m * t.rated_speed_rpm * 2 * math.pi / 60 == pytest.approx(225e6, rel=1e-12)


def test_missing_nets_file_names_key_and_path(tmp_path):
    plant = load_plant(PLANT_FILE, {"turbine.characteristics": "nowhere/nets.json"})
    with pytest.raises(InputError, match=r"turbine\.characteristics = 'nowhere/nets\.json': nets file "
                                         r"'.*nowhere/nets\.json' does not exist"):
        load_characteristics(plant.turbine, plant.base_dir)


def test_plant_config_is_frozen():
    plant = load_plant(PLANT_FILE)
    assert isinstance(plant, PlantConfig)
    with pytest.raises(AttributeError):
        plant.turbine.rated_head_m = 1.0
