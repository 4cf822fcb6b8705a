"""The nets of the Suter curves: the shipped pump-turbine nets against the exact machine, the head and torque they
give, the band, the Wylie-Streeter radial pump, nets.json."""

import json
import math

import numpy as np
import pytest

from data_synthetic import PUMP_TURBINE_DIR
from hillchart.errors import InputError, NumericalError
from hillchart.four_quadrant.nets import (PUMP_TURBINE_CONSTANTS, SHIPPED, band_factor, curve_errors,
                                          load_suter_nets, pump_turbine_test_samples, train_suter_nets,
                                          write_pump_turbine_nets)
from hillchart.four_quadrant.suter import PLAIN, zone
from hillchart.four_quadrant.table import load_complete_characteristics, load_wylie_streeter_curves
from tests.external_charts import require_external

NETS = load_suter_nets(PUMP_TURBINE_DIR / "nets.json")
RATED = NETS.training["rated"]


def test_shipped_nets_are_within_one_percent_of_the_exact_curves_on_unseen_points():
    """817 points at the openings between the table's lines (5, 7, ..., 27 mm) and directions between its points, all
    four quadrants: measured RMS 0.17 % (WH) and 0.09 % (WM) of the curves' range, worst points 1.4 % and 0.6 %. The
    acceptance bound is 1 % RMS; the worst point is bounded at 2 %. The failing case: the curves read on the wrong
    convention's axis (x moved by pi) are tens of percent off."""
    exact = pump_turbine_test_samples(RATED)
    assert exact["x"].size == 817
    assert np.unique(np.floor(exact["x"] / (math.pi / 2))).size == 4  # points in every quarter of the x-axis
    errors = curve_errors(NETS, exact)
    for key in ("wh", "wm"):
        assert errors[key]["rms_pct"] < 1.0 and errors[key]["max_pct"] < 2.0, (key, errors[key])
    shifted = curve_errors(NETS, {**exact, "x": np.mod(exact["x"] + math.pi, 2 * math.pi)})
    assert shifted["wh"]["rms_pct"] > 10.0


def test_the_nets_give_head_and_torque_at_the_tables_turbine_and_pump_points():
    """The inverse with the nets (h solved where x depends on h) at the table's turbine-zone points from 8 mm up, at
    twice their speed and flow (so h = 4): head within 1.5 % (measured 0.4 % RMS, 1.3 % worst), torque within 0.03 of
    the rated torque (measured 0.0035 RMS, 0.025 worst) of the exact machine's; the pump-zone points within 0.1 and
    0.08 (measured 0.08 and 0.07 worst). The failing case: a point in the direction where the machine has no positive
    head is refused."""
    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    rel = table.relative()
    names = zone(rel["speed"], rel["flow"], rel["torque"])
    for name, head_tol, torque_tol in (("turbine", 0.015, 0.03), ("pump", 0.1, 0.08)):
        pick = (names == name) & (table.opening >= 8)
        h, m = NETS.head_torque(2 * rel["speed"][pick], 2 * rel["flow"][pick], rel["opening"][pick])
        assert np.max(np.abs(h / 4 - 1)) < head_tol, name
        assert np.max(np.abs(m / 4 - rel["torque"][pick])) < torque_tol, name
    with pytest.raises(NumericalError, match="the curves give no head at speed 0.01, flow -1.0"):
        NETS.head_torque(0.01, -1.0, 0.5)


def test_the_ensemble_band_is_narrow_and_covers_the_curves_between_the_lines():
    """The shipped nets' band (calibrated on the table's own lines) at the exact machine's 817 unseen points: its
    median width is under 1 % of the curve's range (measured 0.35 and 0.23 %), and it covers at least 85 % of the
    exact curves (measured 89 and 94 %; the aim is 90 %)."""
    exact = pump_turbine_test_samples(RATED)
    band = NETS.band(exact["x"], exact["opening"])
    for key in ("wh", "wm"):
        low, high = band[key]
        assert np.all(low <= high)
        assert np.median(high - low) < 0.01 * np.ptp(exact[key])
        assert np.mean((low <= exact[key]) & (exact[key] <= high)) >= 0.85, key
    assert len(NETS.members) == SHIPPED["members"]


def test_shipped_nets_record_how_they_were_made():
    doc = json.loads((PUMP_TURBINE_DIR / "nets.json").read_text())
    assert doc["constants"] == PUMP_TURBINE_CONSTANTS.to_dict()
    assert doc["inputs"] == ["cos_x", "sin_x", "opening"]
    assert doc["training"]["seed"] == SHIPPED["seed"] and doc["training"]["n_samples"] == 652


@pytest.mark.slow
def test_shipped_nets_regenerate(tmp_path):
    """``python -m hillchart.four_quadrant.nets`` on the shipped table: on one machine the same bytes twice; against
    the shipped file (trained on another CPU, where the compiled LM loop may round differently) the same curves to
    1 % of the range."""
    import shutil

    for name in ("table.csv", "table.toml"):
        shutil.copy(PUMP_TURBINE_DIR / name, tmp_path / name)
    first = write_pump_turbine_nets(tmp_path).read_bytes()
    assert write_pump_turbine_nets(tmp_path).read_bytes() == first
    again = load_suter_nets(tmp_path / "nets.json")
    exact = pump_turbine_test_samples(RATED)
    for a, b in zip(NETS.curves(exact["x"], exact["opening"]), again.curves(exact["x"], exact["opening"])):
        assert np.max(np.abs(a - b)) < 0.01 * np.ptp(a)


@pytest.mark.external
def test_the_wylie_streeter_radial_pump_fits_its_curves():
    """WH(x), WB(x) of the radial pump (n_s 25), 2-8-1 nets on cos x, sin x trained on every other point of the 88
    (x = 2 pi repeats x = 0) and checked on the others: measured RMS 0.44 % (WH) and 0.41 % (WB) of the range; bound
    1 %. The failing case: the curves read with x moved by pi (turbine axis) are far off."""
    folder = require_external("suter_wylie1993_fig7-2.csv")
    radial = load_wylie_streeter_curves(folder / "suter_wylie1993_fig7-2.csv")["radial"]
    x, wh, wb = radial.x[:-1], radial.wh[:-1], radial.wb[:-1]
    train = np.arange(x.size) % 2 == 0
    nets = train_suter_nets({"x": x[train], "wh": wh[train], "wm": wb[train]}, constants=PLAIN,
                            convention="wylie-streeter", hidden=8, restarts=5, members=1)
    errors = curve_errors(nets, {"x": x[~train], "wh": wh[~train], "wm": wb[~train]})
    assert errors["wh"]["rms_pct"] < 1.0 and errors["wm"]["rms_pct"] < 1.0, errors
    shifted = curve_errors(nets, {"x": np.mod(x[~train] + math.pi, 2 * math.pi), "wh": wh[~train], "wm": wb[~train]})
    assert shifted["wh"]["rms_pct"] > 10.0
    with pytest.raises(InputError, match="they take no opening"):
        nets.curves(x, 0.5)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(format="hillsim.nets"), r"format must be 'hillsim.suter_nets' version 1"),
    (lambda d: d.pop("wm"), r"key 'wm' is missing"),
    (lambda d: d.update(constants={"k1": 0.0}), r"constants must be an object with k1, k2, c_h, c_y"),
    (lambda d: d["constants"].update(k2=-1.0), r"SuterConstants.k2 must be a finite number >= 0, got -1.0"),
    (lambda d: d.update(convention="pump"), r"convention must be one of"),
    (lambda d: d["wh"].update(b1=[1.0]), r"b1 must"),
])
def test_bad_nets_files_are_refused_naming_the_key(tmp_path, edit, message):
    doc = json.loads((PUMP_TURBINE_DIR / "nets.json").read_text())
    edit(doc)
    path = tmp_path / "nets.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message):
        load_suter_nets(path)


def test_calibrating_the_band_needs_lines_to_hold_out():
    """Three lines: asked for, a calibration is refused and says why; by default the record says why not (the
    shipped nets, 13 lines, are calibrated)."""
    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    samples = table.suter(PUMP_TURBINE_CONSTANTS)
    three = np.isin(samples["opening"], np.unique(samples["opening"])[:3])
    few = {k: v[three] for k, v in samples.items()}
    with pytest.raises(InputError, match="3 opening lines; calibrating the band between lines needs 4 or more"):
        band_factor(few, constants=PUMP_TURBINE_CONSTANTS)
    with pytest.raises(InputError, match="calibrate needs an ensemble of curves of 4 opening lines or more; these "
                                         "have 3 opening lines"):
        train_suter_nets(few, constants=PUMP_TURBINE_CONSTANTS, hidden=4, restarts=1, members=2, calibrate=True)
    quick = train_suter_nets(few, constants=PUMP_TURBINE_CONSTANTS, hidden=4, restarts=1, members=2)
    assert quick.training["band"] == {"calibrated": False, "why": "3 opening lines (calibrating needs 4)"}
    assert NETS.training["band"]["calibrated"] and NETS.training["band"]["wh"] > 1.0


@pytest.mark.slow
def test_a_calibrated_band_covers_the_curves_between_lines():
    """The shipped table's every other line (4, 8, ..., 28 mm) trained as by default (calibrated) and not (hidden 12, 4
    members, one start; about 5 s): each calibrated member stands its curve's factor times as far from the point
    nets (to 1e-9 of the curve's range: one net of both), and at the exact machine's curves between the table's
    lines (the 817 unseen points of the test above) the calibrated band covers at least 80 % of each curve's values,
    more than the members' own band (measured: 74 and 79 % before, 85 and 84 % calibrated, factors 1.6 and 1.6; the
    failing case: WH's own band under 80 %)."""
    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    samples = table.suter(PUMP_TURBINE_CONSTANTS)
    kept = np.isin(samples["opening"], np.unique(samples["opening"])[::2])
    half = {k: v[kept] for k, v in samples.items()}
    options = dict(constants=PUMP_TURBINE_CONSTANTS, hidden=12, restarts=1, members=4, seed=0)
    plain, wide = train_suter_nets(half, calibrate=False, **options), train_suter_nets(half, **options)
    exact = pump_turbine_test_samples(RATED)
    x, y = exact["x"], exact["opening"]
    record = wide.training["band"]
    for k, key in enumerate(("wh", "wm")):
        span = np.ptp(exact[key])
        point = plain.curves(x, y)[k]
        assert np.allclose(wide.curves(x, y)[k], point, rtol=0, atol=1e-12 * span)  # the point nets are kept
        for (p_m, w_m) in zip(plain.members[1:], wide.members[1:]):
            moved = w_m[k].predict(np.column_stack([np.cos(x), np.sin(x), y]))[:, 0]
            unmoved = p_m[k].predict(np.column_stack([np.cos(x), np.sin(x), y]))[:, 0]
            assert np.allclose(moved - point, record[key] * (unmoved - point), rtol=0, atol=1e-9 * span)
        covered = [np.mean((b[key][0] <= exact[key]) & (exact[key] <= b[key][1]))
                   for b in (plain.band(x, y), wide.band(x, y))]
        assert covered[1] >= 0.8 and covered[1] > covered[0], (key, covered, record)
        if key == "wh":
            assert covered[0] < 0.8
