"""Head envelope along the penstock and extrapolation tracking."""

import json
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from hillchart.nets.hill_nets import load_nets
from simulate.config import load_plant, plant_from_dict, to_dict
from simulate.loop.domain import convex_hull, inside_hull, point_warnings, trusted_domain
from simulate.loop.engine import run_simulation
from simulate.results.envelope import VAPOUR_PRESSURE_HEAD_M, envelope_table

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def nets():
    return load_nets(DATA / "reference_nets.json")


@pytest.fixture(scope="module")
def rejection(nets):
    return run_simulation(load_plant(PLANT_HLA339), characteristics=nets)


@pytest.mark.parametrize("model", ["moc", "rigid"])
def test_envelope_at_the_turbine_node_is_the_turbine_heads_max_and_min(nets, model):
    plant = load_plant(PLANT_HLA339, {"penstock.model": model, "scenario.t_end_s": 20.0})
    r = run_simulation(plant, characteristics=nets)
    # exact equality: the loop folds the very same float into the envelope that it stores as the turbine head
    assert r.envelope_max_m[-1] == r.head_m.max()
    assert r.envelope_min_m[-1] == r.head_m.min()
    # the reservoir node holds the static head exactly
    assert r.envelope_max_m[0] == r.envelope_min_m[0] == plant.penstock.static_head_m
    assert r.envelope_x_m[-1] == pytest.approx(plant.penstock.length_m, rel=1e-12)
    s = r.summary()
    assert s["min_head_m"] == r.head_m.min() and s["max_head_m"] == r.head_m.max()


def test_moc_envelope_has_every_node_and_is_ordered(rejection):
    # 8 reaches on the short segment (180 m / 1180 m/s) and 17 on the long one (320/1120 at the same dt): 26 nodes
    assert rejection.envelope_x_m.size == 1 + rejection.meta["moc_reaches"]
    assert np.all(np.diff(rejection.envelope_x_m) > 0)
    assert np.all(rejection.envelope_max_m >= rejection.envelope_min_m)
    # the water hammer grows towards the valve: the max head rises monotonically along the pipe on this closure
    assert np.all(np.diff(rejection.envelope_max_m) >= -1e-9)


def _profile_plant(axis_drop_m, **penstock):
    """Shipped plant with a profile: the pipe axis at the inlet ``axis_drop_m`` below the reservoir level."""
    raw = to_dict(load_plant(PLANT_HLA339))
    raw["penstock"].update(penstock)
    top = raw["penstock"]["static_head_m"] - axis_drop_m
    segs = raw["penstock"]["segments"]
    segs[0].update(elevation_start_m=top, elevation_end_m=top - 5.0)
    segs[1].update(elevation_start_m=top - 5.0, elevation_end_m=-5.0)
    return plant_from_dict(raw, base_dir=Path(PLANT_HLA339).parent)


def test_pressure_head_and_column_separation_warning(nets):
    deep = run_simulation(_profile_plant(60.0), characteristics=nets).summary()
    # at the inlet the pressure head is the submergence (60 m) minus nothing: far above the vapour pressure
    assert deep["column_separation"] is False
    table_x = deep["min_pressure_head_x_m"]
    assert 0.0 <= table_x <= 500.0
    # pipe axis 2 m below the reservoir level, then nearly level: the down-surge of the load rejection (about 30 m of
    # head at the turbine, less upstream) takes the pressure head to the vapour pressure near the inlet, where the
    # discrete gas cavity model (the default) holds it just above the vapour head, by the partial pressure of its
    # free gas (measured 1.2 mm; bound 1 cm: the gas of 1e-7 of a node's volume at the atmospheric pressure, grown to
    # a cavity of litres, presses with a millionth of the atmosphere), and reports the cavities
    shallow = run_simulation(_profile_plant(2.0), characteristics=nets)
    s = shallow.summary()
    vapour = s["vapour_pressure_head_m"] - s["atmospheric_pressure_head_m"]
    assert vapour < s["min_pressure_head_m"] <= vapour + 0.01
    assert s["column_separation"] is True and s["cavity_nodes"] >= 1
    assert 0.0 < s["max_cavity_x_m"] <= 500.0
    assert any("gas cavity formed" in w for w in s["warnings"])
    # the discrete vapour cavity model holds the vapour head itself
    dvcm = run_simulation(_profile_plant(2.0, column_separation="dvcm"), characteristics=nets).summary()
    assert dvcm["min_pressure_head_m"] == pytest.approx(vapour, abs=1e-9)
    assert any("vapour cavity formed" in w for w in dvcm["warnings"])
    assert not any("does not represent" in w for w in s["warnings"])
    table = envelope_table(shallow)
    assert set(table) == {"x_m", "head_max_m", "head_min_m", "elevation_m", "pressure_head_max_m",
                          "pressure_head_min_m"}
    np.testing.assert_array_equal(table["pressure_head_min_m"], table["head_min_m"] - table["elevation_m"])
    # the failing case: without column separation the head goes on below the vapour pressure, and the warning says
    # the model does not represent it
    off = run_simulation(_profile_plant(2.0, column_separation="off"), characteristics=nets).summary()
    assert off["min_pressure_head_m"] < VAPOUR_PRESSURE_HEAD_M - 1.0
    assert off["column_separation"] is True
    assert any("which the model does not represent" in w for w in off["warnings"])


def test_profile_garbage_names_the_segment():
    raw = to_dict(load_plant(PLANT_HLA339))
    raw["penstock"]["segments"][1]["elevation_start_m"] = 10.0
    with pytest.raises(InputError, match=r"elevation_start_m and elevation_end_m go together.*\(segment 1"):
        plant_from_dict(raw)
    raw["penstock"]["segments"][1]["elevation_end_m"] = 0.0
    with pytest.raises(InputError, match=r"on every segment or on none; segment 0 has none"):
        plant_from_dict(raw)
    raw["penstock"]["segments"][0].update(elevation_start_m=100.0, elevation_end_m=50.0)
    with pytest.raises(InputError, match=r"segment 1 starts at elevation 10\.0 m but segment 0 ends at 50\.0 m"):
        plant_from_dict(raw)
    raw["penstock"]["segments"][0]["elevation_end_m"] = "high"
    with pytest.raises(InputError, match=r"penstock\.segments\.elevation_end_m must be a number .*'high' \(segment 0"):
        plant_from_dict(raw)


@pytest.mark.parametrize("key,value", [("length_m", -1.0), ("wave_speed_m_s", 1e6), ("diameter_m", 0.0)])
def test_out_of_range_segment_value_names_the_segment(key, value):
    raw = to_dict(load_plant(PLANT_HLA339))
    raw["penstock"]["segments"][1][key] = value
    with pytest.raises(InputError, match=rf"penstock\.segments\.{key} must be in .*\(segment 1, counted from 0"):
        plant_from_dict(raw)


def test_convex_hull_matches_scipy():
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(0)
    pts = rng.normal(size=(200, 2)) * [30.0, 8.0] + [70.0, 20.0]
    hull = convex_hull(pts)
    ref = pts[ConvexHull(pts).vertices]
    assert {tuple(p) for p in hull} == {tuple(p) for p in ref}
    probe = rng.normal(size=(500, 2)) * [40.0, 10.0] + [70.0, 20.0]
    from scipy.spatial import Delaunay

    expected = Delaunay(pts).find_simplex(probe) >= 0
    np.testing.assert_array_equal(inside_hull(hull, probe[:, 0], probe[:, 1], scale=np.ptp(hull, axis=0)), expected)


def _narrowed_nets(nets, n11_max_new):
    """The same function with a declared training range up to ``n11_max_new``: the first-layer N11 weights and biases
    are rescaled so that mapminmax of the new range gives the same hidden inputs (exact up to rounding)."""
    doc = json.loads(nets.to_json())
    for key in ("flow", "torque"):
        block = doc[key]
        lo, hi = block["x_min"][0], block["x_max"][0]
        assert lo == 0.0
        scale = n11_max_new / hi
        for row, b in zip(block["W1"], range(len(block["b1"]))):
            w_old = row[0]
            row[0] = w_old * scale
            block["b1"][b] = block["b1"][b] - w_old + row[0]
        block["x_max"][0] = n11_max_new
    return doc


def test_overspeed_beyond_the_nets_range_is_warned_and_recorded(nets, tmp_path, capsys):
    from hillsim.cli import main

    doc = _narrowed_nets(nets, 100.0)
    (tmp_path / "nets.json").write_text(json.dumps(doc), encoding="utf-8")
    narrowed = load_nets(tmp_path / "nets.json")
    n11 = np.linspace(40, 100, 7)
    np.testing.assert_allclose(narrowed.q11(n11, 20.0), nets.q11(n11, 20.0), rtol=1e-12)
    text = Path(PLANT_HLA339).read_text(encoding="utf-8").replace(
        'characteristics = "francis/nets.json"', f'characteristics = "{(tmp_path / "nets.json").as_posix()}"')
    (tmp_path / "plant.toml").write_text(text, encoding="utf-8")
    assert main(["run", str(tmp_path / "plant.toml"), "--out", str(tmp_path / "out"), "--no-plot"]) == 0
    err = capsys.readouterr().err
    assert "warning: outside the nets' training range" in err and "trained on N11 0-100" in err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    rec = summary["extrapolation"]["training_range"]
    assert 0.0 < rec["fraction_of_time"] < 1.0 and 100.0 < rec["n11_max"] < 110.0
    # the same run with the real range (0-125.38): nothing outside the training range, no such warning
    assert main(["run", str(PLANT_HLA339), "--out", str(tmp_path / "out2"), "--no-plot"]) == 0
    assert "training range" not in capsys.readouterr().err
    summary = json.loads((tmp_path / "out2" / "summary.json").read_text())
    assert summary["extrapolation"]["training_range"] == {"fraction_of_time": 0.0}
    assert summary["extrapolation"]["digitized_region"]["fraction_of_time"] > 0.5  # shut vanes: outside the lines


def test_start_with_negative_power_or_outside_the_training_range_is_an_error(nets):
    """Rated speed 380 r/min at full opening (N11 128, -21.6 MW) is refused, not run as a 'load rejection'."""
    plant = load_plant(PLANT_HLA339, {"turbine.rated_speed_rpm": 380.0, "scenario.initial_power_mw": None,
                                      "scenario.initial_opening": 1.0})
    with pytest.raises(InputError, match=r"negative power -21\.6\d* MW \(N11 = 12[0-9.]+ r/min.*"
                                         r"turbine\.rated_speed_rpm = 380\.0"):
        run_simulation(plant, characteristics=nets)
    # a power target the unit cannot give at that speed was already a clean error
    with pytest.raises(InputError, match=r"scenario\.initial_power_mw = 225\.0 is outside the power range"):
        run_simulation(load_plant(PLANT_HLA339, {"turbine.rated_speed_rpm": 380.0}), characteristics=nets)
    # positive power but N11 above the training range (nets declared up to 70 r/min, start at 67.8 * 380/200)
    from simulate.loop.guards import check_initial_state
    from simulate.loop.domain import TrustedDomain
    from simulate.loop.engine import initial_state

    plant = load_plant(PLANT_HLA339)
    steady = initial_state(plant, nets)
    check_initial_state(plant, steady, TrustedDomain((0.0, 125.0), (0.0, 32.0)))  # inside: no error
    with pytest.raises(InputError, match=r"outside the characteristics' trusted domain: outside the nets' training "
                                         r"range \(N11 0-60 r/min"):
        check_initial_state(plant, steady, TrustedDomain((0.0, 60.0), (0.0, 32.0)))


def test_point_warnings_for_linearize(nets):
    assert point_warnings(nets, 67.8, 23.46, opening_max=32.0) == []
    warns = point_warnings(nets, 200.0, 50.0, opening_max=32.0)
    assert any("training range" in w for w in warns) and any("full guide-vane stroke" in w for w in warns)
    # each says what to do about it
    assert any(w.endswith("choose a point in that range, or extend the chart and retrain") for w in warns), warns
    assert any(w.endswith("no chart line is above full stroke; check --opening against turbine.opening_max")
               for w in warns), warns
    region = point_warnings(nets, 100.0, 2.0, chart_dir=Path(PLANT_HLA339).parent / "francis", opening_max=32.0)
    assert len(region) == 1 and "outside the digitized region" in region[0]
    assert region[0].endswith("digitize the chart up to this point to rest the coefficients on data")
    domain = trusted_domain(nets, chart_dir=Path(PLANT_HLA339).parent / "francis")
    assert domain.hull is not None and len(domain.hull) >= 3
    assert domain.masks(67.8, 23.46, 0.7)["digitized_region"] == False  # noqa: E712  (numpy bool)
    assert domain.masks(67.8, 2.0, 0.06)["digitized_region"] == True  # noqa: E712


def test_linearize_warns_outside_the_domain(capsys):
    from hillsim.cli import main

    nets_path = str(Path(PLANT_HLA339).parent / "francis" / "nets.json")
    assert main(["linearize", nets_path, "--n11", "200", "--opening", "50"]) == 0
    captured = capsys.readouterr()
    assert "warning: N11 = 200 r/min, opening 50 is outside the nets' training range" in captured.err
    assert json.loads(captured.out)["warnings"]
    assert main(["linearize", nets_path, "--n11", "67.8", "--opening", "23.46"]) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err and json.loads(captured.out)["warnings"] == []


def test_extrapolation_warning_prints_no_subnormal_openings():
    """Float noise: a servo closing exponentially leaves openings like 1.1e-109; the warning says 0."""
    from simulate.loop.domain import extrapolation_warnings

    entry = {"fraction_of_time": 0.9, "first_time_s": 5.47, "n11_min": 82.27, "n11_max": 106.7,
             "opening_min": 1.1e-109, "opening_max": 12.49, "stroke_max": 0.39}
    (line,) = extrapolation_warnings({"digitized_region": entry})
    assert "opening 0-12.49" in line and "e-109" not in line
