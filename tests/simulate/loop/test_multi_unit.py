"""Plants with several units on a conduit that branches at a manifold: the junction against the series junction of
the single-unit loop, mass balance and common head at every step, one unit rejecting while the other runs on, the
steady state, the output record."""

import math
import tomllib

import numpy as np
import pytest

from data_synthetic import PLANT_TWO_UNITS
from hillchart.errors import InputError
from simulate.config import load_plant, plant_from_dict
from simulate.loop.engine import run_simulation

GOVERNOR = {"kp": 2.0, "ki": 0.4, "kd": 0.5, "derivative_filter_s": 0.2, "permanent_droop": 0.0,
            "servo_time_s": 0.2, "closing_time_s": 12.0, "opening_time_s": 20.0}
COMMON = {"length_m": 320.0, "diameter_m": 8.6, "wave_speed_m_s": 1120.0, "darcy_friction": 0.0}


def _turbine(scale):
    return {"rated_head_m": 176.0, "rated_flow_m3_s": 142.5 * scale, "rated_speed_rpm": 200.0,
            "rated_power_mw": 225.0 * scale, "runner_diameter_m": 4.5, "opening_max": 32.0,
            "characteristics": "ideal"}


def _branch(diameter_m):
    return {"length_m": 180.0, "diameter_m": diameter_m, "wave_speed_m_s": 1180.0, "darcy_friction": 0.0}


def _raw(scale, t_end_s=20.0):
    return {"turbine": _turbine(scale),
            # the quasi-steady loss: the unsteady friction's weights depend on the diameter, so a branch of twice the
            # area is not two branches with it (the equivalences below are the junction's algebra); the DVCM, whose
            # liquid nodes are the plain MOC: the DGCM's free gas follows each node's pipe volume, which a branching
            # junction and a series one divide differently
            "penstock": {"model": "moc", "static_head_m": 180.0, "reaches": 8, "segments": [dict(COMMON)],
                         "friction_model": "steady", "column_separation": "dvcm"},
            "generator": {"inertia_time_s": 9.0, "self_regulation": 1.0}, "governor": dict(GOVERNOR),
            "scenario": {"kind": "load-rejection", "t_end_s": t_end_s, "initial_power_mw": 225.0 * scale,
                         "event_time_s": 1.0},
            "solver": {"pressure_loop": "newton"}}


def two_units(t_end_s=20.0, **scenario):
    raw = _raw(1.0, t_end_s)
    raw["units"] = [{"name": "U1", "branch": [_branch(4.0)]}, {"name": "U2", "branch": [_branch(4.0)]}]
    raw["scenario"].update(scenario)
    return plant_from_dict(raw)


@pytest.fixture(scope="module")
def both_reject():
    return run_simulation(two_units())


@pytest.fixture(scope="module")
def one_rejects():
    return run_simulation(two_units(t_end_s=40.0, units=["U1"]))


def test_two_identical_units_are_one_unit_of_twice_the_flow_on_a_branch_of_twice_the_area(both_reject):
    """Two ideal units on identical frictionless branches, both rejecting, against the single-unit loop with one unit
    of twice the rated flow and power whose penstock is the common pipe and then one pipe of twice the branch area:
    the manifold's branching junction must give the series junction's head at every step."""
    raw = _raw(2.0)
    raw["penstock"]["segments"].append(_branch(4.0 * math.sqrt(2.0)))
    single = run_simulation(plant_from_dict(raw))
    assert both_reject.meta["dt_s"] == pytest.approx(single.meta["dt_s"], rel=1e-14)
    assert single.time_s.size == both_reject.time_s.size
    for name in ("U1", "U2"):
        unit = both_reject.units[name]
        # 1e-9 relative: the same equations in another order (a sum over two branches for one interior node); round-off
        # of ~1e-15 a step over ~2000 steps of a damped transient stays far below it
        assert np.max(np.abs(unit["head_m"] - single.head_m)) <= 1e-9 * single.head_m.max()
        assert np.max(np.abs(unit["speed_rpm"] - single.speed_rpm)) <= 1e-9 * single.speed_rpm.max()
        assert np.max(np.abs(2.0 * unit["flow_m3_s"] - single.flow_m3_s)) <= 1e-9 * single.flow_m3_s.max()
    # the check can fail: a branch 1 % wider is another plant, far outside 1e-9
    raw["penstock"]["segments"][-1]["diameter_m"] *= 1.01
    other = run_simulation(plant_from_dict(raw))
    assert np.max(np.abs(both_reject.units["U1"]["head_m"] - other.head_m)) > 1e-3 * other.head_m.max()
    # a rejection of both units is a real transient: the head rises by percents
    assert single.summary()["max_head_rise"] > 0.05


def _junction_errors(result):
    j = result.junction
    names = result.meta["unit_names"]
    inflow = sum(j[f"{n}.branch_inlet_flow_m3_s"] for n in names)
    mass = np.abs(j["conduit_outlet_flow_m3_s"] - inflow)
    heads = [np.abs(j["conduit_outlet_head_m"] - j[f"{n}.branch_inlet_head_m"]) for n in names]
    return mass, np.max(heads, axis=0), j


@pytest.mark.parametrize("fixture", ["both_reject", "one_rejects"])
def test_junction_mass_balance_and_common_head_at_every_step(fixture, request):
    result = request.getfixturevalue(fixture)
    mass, head, j = _junction_errors(result)
    q_scale = np.max(np.abs(j["conduit_outlet_flow_m3_s"]))
    h_scale = np.max(j["conduit_outlet_head_m"])
    # 1e-9 of the scale: the pipes' states after their updates (the common pipe's last node, each branch's first) are
    # written from one solved junction; only round-off (~1e-16 relative) separates them
    assert mass.max() <= 1e-9 * q_scale
    assert head.max() <= 1e-9 * h_scale
    # the manifold head in the output is that head
    assert np.max(np.abs(result.signals["manifold_head_m"] - j["conduit_outlet_head_m"])) <= 1e-9 * h_scale
    # the check can fail: leaving one branch out of the balance misses half the flow
    assert np.max(np.abs(j["conduit_outlet_flow_m3_s"] - j["U1.branch_inlet_flow_m3_s"])) > 0.2 * q_scale


def test_one_unit_rejects_while_the_other_runs_on_under_its_governor(one_rejects):
    s = one_rejects.summary()
    u1, u2 = s["units"]["U1"], s["units"]["U2"]
    assert s["event_units"] == ["U1"] and s["series_unit"] == "U1"
    # the rejecting unit runs away towards its overspeed; the running one only feels the pressure wave
    assert u1["max_speed_rise"] > 0.2
    assert 1e-3 < u2["max_speed_rise"] < 0.05
    # the running unit's power swings with the head at its inlet (the wave of the other unit's closure) ...
    assert u2["max_power_mw"] - u2["min_power_mw"] > 5.0
    assert u2["max_head_m"] > u2["initial_head_m"] + 5.0
    # ... and its governor (no permanent droop) brings it back to the rated speed and its load
    assert abs(u2["final_speed_error"]) < 2e-3
    assert one_rejects.units["U2"]["power_mw"][-1] == pytest.approx(225.0, rel=0.01)
    # the plant-level maxima are the worst over the units
    assert s["max_speed_rise"] == u1["max_speed_rise"] and s["max_speed_rise_unit"] == "U1"
    assert s["max_head_m"] == max(u1["max_head_m"], u2["max_head_m"])


def test_steady_state_shares_the_common_loss():
    """With friction in the common pipe the manifold head is the static head less K_c (Q1 + Q2)^2."""
    from simulate.loop.multi_unit import unit_characteristics, units_initial_state

    raw = _raw(1.0)
    raw["penstock"]["segments"][0]["darcy_friction"] = 0.012
    raw["scenario"]["initial_power_mw"] = 200.0
    raw["units"] = [{"name": "A", "branch": [_branch(4.0) | {"darcy_friction": 0.012}]},
                    {"name": "B", "branch": [_branch(4.0)], "initial_power_mw": 100.0}]
    plant = plant_from_dict(raw)
    steady = units_initial_state(plant, unit_characteristics(plant))
    total = sum(u.flow_m3_s for u in steady.units)
    k_c = plant.penstock.friction_coefficient_s2_m5
    assert steady.head_m == pytest.approx(180.0 - k_c * total ** 2, rel=1e-12)
    assert steady.units[0].power_mw == pytest.approx(200.0, rel=1e-9)
    assert steady.units[1].power_mw == pytest.approx(100.0, rel=1e-9)
    # unit A's branch has friction, unit B's none: A sees less head than the manifold, B all of it
    assert steady.units[0].head_m < steady.head_m - 0.1
    assert steady.units[1].head_m == pytest.approx(steady.head_m, rel=1e-12)
    # a target the unit cannot reach names the unit and what to set
    raw["units"][1]["initial_power_mw"] = 300.0
    with pytest.raises(InputError, match=r"unit 'B' at the manifold head .*units.initial_power_mw"):
        plant = plant_from_dict(raw)
        units_initial_state(plant, unit_characteristics(plant))


def test_output_columns_and_summary(both_reject, tmp_path):
    import json

    columns = both_reject.columns()
    for name in ("U1.speed_rpm", "U2.head_m", "U1.flow_m3_s", "U2.opening", "U1.power_mw", "manifold_head_m"):
        assert name in columns
    summary = json.loads(both_reject.to_json(tmp_path / "summary.json").read_text())
    assert set(summary["units"]) == {"U1", "U2"}
    assert summary["units"]["U2"]["max_head_m"] == pytest.approx(both_reject.units["U2"]["head_m"].max(), rel=1e-11)


def test_plain_python_loop_equals_the_compiled_one():
    plant = two_units(t_end_s=1.5, units=["U2"])
    compiled = run_simulation(plant)
    python = run_simulation(plant, jit=False)
    assert compiled.meta["compiled"] and not python.meta["compiled"]
    # the same generated source run by numba and by Python: LLVM may fuse or reorder nothing here but libm calls can
    # differ in the last ulp; 1e-12 relative over ~300 steps
    for name in ("U1", "U2"):
        for key in ("head_m", "speed_rpm", "flow_m3_s"):
            a, b = compiled.units[name][key], python.units[name][key]
            assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))


def test_shipped_two_unit_plant_reads_and_starts():
    plant = load_plant(PLANT_TWO_UNITS, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0})
    result = run_simulation(plant)
    assert result.success and set(result.units) == {"U1", "U2"}
    raw = tomllib.loads(PLANT_TWO_UNITS.read_text())
    assert [u["name"] for u in raw["units"]] == ["U1", "U2"]


def test_units_with_different_kinds_of_characteristics_are_refused():
    raw = _raw(1.0)
    raw["units"] = [{"name": "U1", "branch": [_branch(4.0)]},
                    {"name": "U2", "branch": [_branch(4.0)], "turbine": {"characteristics": "synthetic"}}]
    with pytest.raises(InputError, match=r"unit 'U2': turbine.characteristics = 'synthetic' is another kind of "
                                         r"characteristics than those of unit 'U1' \('ideal'\)"):
        run_simulation(plant_from_dict(raw))
