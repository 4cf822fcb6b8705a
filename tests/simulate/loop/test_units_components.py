"""Every component in every plant shape: a unit of a plant with ``[[units]]`` with a draft tube, and a
double-regulated unit (blade servo and combinator, three-input characteristics), against the same plant without
``[[units]]`` and against each other."""

import copy
import math
import tomllib

import numpy as np
import pytest

from data_synthetic import PLANT_BULB
from simulate.config import plant_from_dict
from simulate.loop.engine import run_simulation

BULB = tomllib.loads(PLANT_BULB.read_text(encoding="utf-8"))


def _bulb(units=None, t_end_s=12.0, characteristics="synthetic-bulb"):
    """The shipped bulb plant with its 40 m intake as two 20 m pipes: in series (no ``[[units]]``), or the first
    the common conduit and the second each unit's branch."""
    raw = copy.deepcopy(BULB)
    raw["penstock"]["column_separation"] = "dvcm"  # as in test_multi_unit.py: the junction's algebra
    raw["turbine"]["characteristics"] = characteristics
    raw["scenario"]["t_end_s"] = t_end_s
    half = dict(raw["penstock"]["segments"][0], length_m=20.0)
    if units is None:
        raw["penstock"]["segments"] = [dict(half), dict(half)]
    else:
        raw["penstock"]["segments"] = [dict(half)]
        raw["units"] = [{"name": name, "branch": [dict(half)]} for name in units]
    return plant_from_dict(raw, base_dir=PLANT_BULB.parent)


def test_one_double_regulated_unit_with_a_draft_tube_in_units_is_the_plant_without_units():
    """The bulb (draft tube, blade servo, combinator, three-input characteristics) as the one unit of a plant with
    [[units]] against the same waterway without [[units]]: the manifold with one branch is the series junction of two
    segments, so every series and the draft tube's and the blades' columns agree."""
    single = run_simulation(_bulb())
    one = run_simulation(_bulb(["U1"]))
    assert one.meta["dt_s"] == single.meta["dt_s"] and one.time_s.size == single.time_s.size
    unit = one.units["U1"]
    # 1e-9 of each series' largest value: the same equations with the junction solved in another order (measured
    # 7e-11 for the head, which rises by 100 % in this rejection); a wrong index or a missing draft tube is O(1e-2)
    for name in ("head_m", "speed_rpm", "flow_m3_s", "opening", "torque_nm"):
        reference = getattr(single, name)
        assert np.max(np.abs(unit[name] - reference)) <= 1e-9 * np.max(np.abs(reference)), name
    for name in ("blade_angle_deg", "blade_angle_cam_deg", "draft_tube_head_m", "outlet_pressure_head_m"):
        reference = single.signals[name]
        assert np.max(np.abs(one.signals[f"U1.{name}"] - reference)) <= 1e-9 * np.max(np.abs(reference)), name
    assert one.component_figures["U1.min_outlet_pressure_head_m"] == pytest.approx(
        single.component_figures["min_outlet_pressure_head_m"], rel=1e-9)
    assert single.summary()["max_head_rise"] > 0.5  # a real transient
    # the check can fail: the unit's draft tube 10 % wider is another plant
    raw = copy.deepcopy(BULB)
    raw["draft_tube"]["segments"][0]["diameter_m"] *= 1.1
    raw["turbine"]["characteristics"], raw["scenario"]["t_end_s"] = "synthetic-bulb", 12.0
    half = dict(raw["penstock"]["segments"][0], length_m=20.0)
    raw["penstock"]["segments"] = [dict(half), dict(half)]
    other = run_simulation(plant_from_dict(raw, base_dir=PLANT_BULB.parent))
    assert np.max(np.abs(unit["head_m"] - other.head_m)) > 1e-4 * np.max(other.head_m)


GOVERNOR = {"kp": 2.0, "ki": 0.4, "kd": 0.5, "derivative_filter_s": 0.2, "permanent_droop": 0.0,
            "servo_time_s": 0.2, "closing_time_s": 12.0, "opening_time_s": 20.0}


def _francis(scale: float, branch_diameter_m: float, draft_diameter_m: float | None, units=None, own=None):
    """Ideal Francis units of ``scale`` x the rated flow and power on a 320 m common pipe, with a 180 m branch each
    (or, without ``units``, the branch as the penstock's second segment) and a 38 m draft tube each (two reaches of
    the grid); ``own``: a unit's own sections by its name (``{"U2": {"governor": {...}}}``)."""
    branch = {"length_m": 180.0, "diameter_m": branch_diameter_m, "wave_speed_m_s": 1180.0, "darcy_friction": 0.0}
    raw = {"turbine": {"rated_head_m": 176.0, "rated_flow_m3_s": 142.5 * scale, "rated_speed_rpm": 200.0,
                       "rated_power_mw": 225.0 * scale, "runner_diameter_m": 4.5, "opening_max": 32.0,
                       "characteristics": "ideal"},
           # the quasi-steady loss (frictionless here): the unsteady friction's weights depend on the diameter; the
           # DVCM (no cavity: the plain MOC): the DGCM's free gas follows each node's pipe volume, which a branching
           # junction and a series one divide differently
           "penstock": {"model": "moc", "static_head_m": 180.0, "reaches": 8, "friction_model": "steady",
                        "column_separation": "dvcm",
                        "segments": [{"length_m": 320.0, "diameter_m": 8.6, "wave_speed_m_s": 1120.0,
                                      "darcy_friction": 0.0}]},
           "generator": {"inertia_time_s": 9.0, "self_regulation": 1.0}, "governor": dict(GOVERNOR),
           "scenario": {"kind": "load-rejection", "t_end_s": 15.0, "initial_power_mw": 225.0 * scale,
                        "event_time_s": 1.0},
           "solver": {"pressure_loop": "newton"}}
    if draft_diameter_m is not None:
        raw["draft_tube"] = {"model": "moc", "runner_elevation_m": -2.0, "friction_model": "steady",
                             "segments": [{"length_m": 38.0, "diameter_m": draft_diameter_m,
                                           "wave_speed_m_s": 1000.0, "darcy_friction": 0.0}]}
    if units is None:
        raw["penstock"]["segments"].append(branch)
    else:
        raw["units"] = [{"name": name, "branch": [dict(branch)], **(own or {}).get(name, {})} for name in units]
    return plant_from_dict(raw)


def test_two_identical_units_with_draft_tubes_share_a_load_rejection():
    """Two identical units, each with its draft tube, both rejecting on the common conduit: their series are the same
    to the bit (the same arithmetic on the same numbers), and each is one unit of twice the flow on a branch and a
    draft tube of twice the area (the plant without [[units]]), whose head rise the units' is."""
    both = run_simulation(_francis(1.0, 4.0, 4.0, ["U1", "U2"]))
    u1, u2 = both.units["U1"], both.units["U2"]
    for name in ("head_m", "speed_rpm", "flow_m3_s", "opening", "torque_nm"):
        np.testing.assert_array_equal(u1[name], u2[name])
    np.testing.assert_array_equal(both.signals["U1.outlet_pressure_head_m"], both.signals["U2.outlet_pressure_head_m"])
    root2 = math.sqrt(2.0)
    single = run_simulation(_francis(2.0, 4.0 * root2, 4.0 * root2))
    assert single.time_s.size == both.time_s.size
    # 1e-9 of the scale: the branching junction against the series junction, the same equations in another order
    # (round-off, see test_multi_unit.py); a unit's draft tube left out would be 1e-3 off (below)
    assert np.max(np.abs(u1["head_m"] - single.head_m)) <= 1e-9 * single.head_m.max()
    assert np.max(np.abs(2.0 * u1["flow_m3_s"] - single.flow_m3_s)) <= 1e-9 * single.flow_m3_s.max()
    summary, reference = both.summary(), single.summary()
    assert reference["max_head_rise"] > 0.05  # a real water hammer
    assert summary["units"]["U1"]["max_head_rise"] == pytest.approx(reference["max_head_rise"], rel=1e-9)
    assert both.component_figures["U2.min_outlet_pressure_head_m"] == pytest.approx(
        single.component_figures["min_outlet_pressure_head_m"], rel=1e-9)
    # the check can fail: the same two units discharging straight to the tailwater
    without = run_simulation(_francis(1.0, 4.0, None, ["U1", "U2"]))
    assert np.max(np.abs(without.units["U1"]["head_m"] - single.head_m)) > 1e-3 * single.head_m.max()


def _bulb_two_units(mode: str):
    """The shipped bulb plant (its nets) with its intake as the common conduit and two 15 m branches of half the
    area; unit U1's load is rejected, U2 stays on its load under its governor."""
    raw = copy.deepcopy(BULB)
    raw["scenario"].update(t_end_s=40.0, units=["U1"])
    raw["blade_servo"]["mode"] = mode
    branch = {"length_m": 15.0, "diameter_m": 6.0 / math.sqrt(2.0), "wave_speed_m_s": 1000.0, "darcy_friction": 0.014}
    raw["units"] = [{"name": name, "branch": [dict(branch)]} for name in ("U1", "U2")]
    return plant_from_dict(raw, base_dir=PLANT_BULB.parent)


@pytest.mark.slow
def test_the_shipped_bulb_plant_as_two_units_runs_and_each_units_blades_follow_the_combinator():
    result = run_simulation(_bulb_two_units("combinator"))
    servo = BULB["blade_servo"]
    span = servo["angle_max_deg"] - servo["angle_min_deg"]
    fastest = span / min(servo["closing_time_s"], servo["opening_time_s"])  # deg/s, the servo's rate limit
    dt = result.time_s[1] - result.time_s[0]
    for name in ("U1", "U2"):
        blade, cam = result.signals[f"{name}.blade_angle_deg"], result.signals[f"{name}.blade_angle_cam_deg"]
        assert blade[0] == pytest.approx(cam[0], abs=1e-9)  # on the cam at t = 0
        assert np.ptp(cam) > 5.0  # the cam moves with the vanes (and the head) of each unit
        # the blades move no faster than their servo's rate limit (1e-9: the servo's own arithmetic)
        assert np.max(np.abs(np.diff(blade))) <= fastest * dt * (1.0 + 1e-9)
    # the rejecting unit's vanes shut: its cam goes to the flattest blade, and the blades reach it (1e-6 deg: a
    # first-order servo many time constants on)
    blade, cam = result.signals["U1.blade_angle_deg"], result.signals["U1.blade_angle_cam_deg"]
    assert cam[-1] == pytest.approx(servo["angle_min_deg"], abs=1e-9)
    assert abs(blade[-1] - cam[-1]) < 1e-6
    # the running unit's blades follow its cam to within the servo's lag: the gap at the end is a small part of the
    # largest gap while the cam moved
    blade, cam = result.signals["U2.blade_angle_deg"], result.signals["U2.blade_angle_cam_deg"]
    assert abs(blade[-1] - cam[-1]) < 0.05 * np.max(np.abs(blade - cam))
    assert result.summary()["units"]["U1"]["max_speed_rise"] > 0.2
    # the check can fail: blades held by their servo stay where they started while the cam moves away
    held = run_simulation(_bulb_two_units("held"))
    blade, cam = held.signals["U1.blade_angle_deg"], held.signals["U1.blade_angle_cam_deg"]
    assert np.ptp(blade) == 0.0 and abs(blade[-1] - cam[-1]) > 5.0


def test_the_draft_tubes_lowest_pressure_limit_takes_the_worst_unit():
    """Two units with draft tubes, U2's vanes closing in 8 s (U1's in 12 s): each gives its
    ``U.min_draft_tube_pressure_head_m`` and U2's is the lower (its draft tube's column decelerates faster); the
    guarantee's limit judges that one, the worst, where before it found no figure; the ensemble band reads the same
    (``worst_over_units``)."""
    from simulate.studies.case_results import case_from_result, worst_over_units
    from simulate.studies.cases import Limits

    plant = _francis(1.0, 4.0, 4.0, ["U1", "U2"], own={"U2": {"governor": {"closing_time_s": 8.0}}})
    result = run_simulation(plant)
    figures = result.component_figures
    u1, u2 = (figures[f"{u}.min_draft_tube_pressure_head_m"] for u in ("U1", "U2"))
    assert u2 < u1 - 0.1  # measured 5.89 against 6.81 m: far more than round-off apart
    assert u2 == pytest.approx(figures["U2.min_outlet_pressure_head_m"], rel=1e-12)  # no profile: the runner's
    case = case_from_result(0, {}, plant, result)
    assert "min_draft_tube_pressure_head_m" not in case.components  # the plant-level name alone finds nothing
    for allowed, verdict in ((u2 - 0.01, "PASS"), (u2 + 0.01, "FAIL")):  # U1 alone would pass the second
        (row,) = Limits(min_draft_tube_pressure_head_m=allowed).check(case)
        assert row["verdict"] == verdict and row["value"] == pytest.approx(u2, rel=1e-12)
    assert worst_over_units(result.summary(), "min_draft_tube_pressure_head_m") == pytest.approx(u2, rel=1e-12)
