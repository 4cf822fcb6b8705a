"""The ``[[units]]`` of a plant file and ``scenario.units``: each bad input named with its field, value and what is
allowed; a plant without units unchanged."""

import tomllib

import pytest

from data_synthetic import PLANT_HLA339, PLANT_TWO_UNITS
from hillchart.errors import InputError
from simulate.config import load_plant, plant_from_dict, to_dict


def _raw():
    return tomllib.loads(PLANT_TWO_UNITS.read_text(encoding="utf-8"))


def test_units_read_with_overrides_and_round_trip():
    raw = _raw()
    raw["units"][1]["turbine"] = {"rated_power_mw": 200.0}
    raw["units"][1]["governor"] = {"kp": 3.0}
    raw["units"][1]["initial_power_mw"] = 150.0
    plant = plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)
    u1, u2 = plant.units
    assert (u1.name, u2.name) == ("U1", "U2")
    assert u1.turbine == plant.turbine and u2.turbine.rated_power_mw == 200.0
    assert u2.turbine.rated_flow_m3_s == plant.turbine.rated_flow_m3_s  # keys not overridden come from [turbine]
    assert u2.governor.kp == 3.0 and u2.governor.ki == plant.governor.ki
    assert u2.branch[0].length_m == 180.0
    assert plant.event_units == ("U1",)
    view = plant.unit_plant(u2)
    assert view.scenario.initial_power_mw == 150.0 and view.penstock.segments == u2.branch
    # the TOML-shaped dict keeps only the units' own keys, so a plant-level override reaches the others
    again = plant_from_dict(to_dict(plant), base_dir=plant.base_dir)
    assert again.units == plant.units
    changed = plant.with_overrides({"governor.ki": 0.5})
    assert changed.units[0].governor.ki == 0.5 and changed.units[1].governor.kp == 3.0
    no_list = _raw()
    del no_list["scenario"]["units"]
    assert plant_from_dict(no_list, base_dir=plant.base_dir).event_units == ("U1", "U2")  # default: all units


def test_a_plant_without_units_is_unchanged():
    plant = load_plant(PLANT_HLA339)
    assert plant.units == () and plant.event_units == ()
    assert "units" not in to_dict(plant) and "units" not in to_dict(plant)["scenario"]


def _bad(change, match):
    raw = _raw()
    change(raw)
    with pytest.raises(InputError, match=match):
        plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)


@pytest.mark.parametrize("change, match", [
    (lambda r: r["scenario"].update(units=["U3"]), r"scenario.units names 'U3', which is not a unit of this plant; "
                                                   r"the units are U1, U2"),
    (lambda r: r["scenario"].update(units=[]), r"scenario.units must be a non-empty list of unit names"),
    (lambda r: r["scenario"].update(units=["U1", "U1"]), r"scenario.units names a unit twice"),
    (lambda r: r["units"][1].update(name="U1"), r"units.name 'U1' is given twice"),
    (lambda r: r["units"][1].update(name="U 2"), r"units.name must be a non-empty name of letters, digits, _ and -, "
                                                 r"got 'U 2'"),
    (lambda r: r["units"][0].update(colour="red"), r"unknown key units.colour \(unit 0\); valid keys of \[\[units\]\]: "
                                                   r"name, branch, turbine"),
    (lambda r: r["units"][0].pop("branch"), r"missing required key units.branch \(unit 0\)"),
    (lambda r: r["units"][0].update(branch=[]), r"units.branch must be a non-empty array of tables"),
    (lambda r: r["units"][0]["branch"][0].update(diameter_m=-2.0),
     r"units.branch.diameter_m must be in \(0.0, 30.0\], got -2.0 \(segment 0.*\(unit 'U1'\)"),
    (lambda r: r["units"][0]["branch"][0].update(length=3.0), r"unknown key units.branch.length \(segment 0\)"),
    (lambda r: r["units"][0].update(turbine={"rated_powr_mw": 3.0}),
     r"unknown key turbine.rated_powr_mw; valid keys of \[turbine\].*\(in \[units.turbine\] of unit 'U1'\)"),
    (lambda r: r["units"][0].update(governor={"kp": -1.0}),
     r"governor.kp must be in \[0.0, 1000.0\], got -1.0 \(in \[units.governor\] of unit 'U1'\)"),
    (lambda r: r["units"][0].update(turbine=3.0), r"units.turbine \(unit 'U1'\) must be a table"),
    (lambda r: r["units"][0].update(initial_power_mw=1000.0),
     r"units.initial_power_mw \(unit 'U1'\) must be in \[0.0, 337.5\], got 1000.0"),
    (lambda r: r.update(units={"name": "U1"}), r"units must be a non-empty array of tables \[\[units\]\]"),
    (lambda r: r["penstock"].update(model="rigid"), r"penstock.model = 'rigid': a plant with \[\[units\]\] computes "
                                                   r"the common conduit .* set penstock.model = \"moc\""),
    (lambda r: r["solver"].update(dt_s=0.01), r"solver.dt_s = 0.01: a plant with \[\[units\]\] steps on the grid"),
    (lambda r: r["units"][0].update(generator={"model": "subtransient"}), r"generator"),
])
def test_bad_units_input_names_the_field_the_value_and_what_is_allowed(change, match):
    _bad(change, match)


def test_scenario_units_need_a_plant_with_units():
    raw = tomllib.loads(PLANT_HLA339.read_text(encoding="utf-8"))
    raw["scenario"]["units"] = ["U1"]
    with pytest.raises(InputError, match=r"scenario.units = \['U1'\] needs a plant with \[\[units\]\]"):
        plant_from_dict(raw, base_dir=PLANT_HLA339.parent)


def test_overriding_the_units_from_the_command_line_is_refused_with_the_reason():
    with pytest.raises(InputError, match=r"the units are changed in the plant file"):
        load_plant(PLANT_TWO_UNITS, {"units.name": "X"})


def test_the_time_step_is_the_shortest_pipe_of_conduit_and_branches():
    raw = _raw()
    raw["units"][1]["branch"][0]["length_m"] = 90.0  # half the travel time of the other pipes
    plant = plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)
    assert plant.time_step_s == pytest.approx(90.0 / 1180.0 / 8, rel=1e-14)


def test_the_run_size_counts_the_nodes_of_every_branch():
    from simulate.loop.guards import estimate

    plant = load_plant(PLANT_TWO_UNITS)
    dt = plant.time_step_s
    # common conduit 320 m / (1120 m/s x dt) = 15 reaches, each branch 180 m / (1180 m/s x dt) = 8 reaches:
    # 16 + 9 + 9 nodes
    assert estimate(plant, dt, 100, 1)["nodes"] == 34
    assert estimate(load_plant(PLANT_HLA339), dt, 100, 1)["nodes"] == 24  # one pipe of two segments: 15 + 8 + 1
