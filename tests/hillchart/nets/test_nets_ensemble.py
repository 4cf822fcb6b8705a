"""nets.json with an ensemble, and nets.json loading that never ends in a traceback."""

import json

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.errors import InputError
from hillchart.linearize import COEFFICIENT_NAMES, six_coefficients, six_coefficients_band
from hillchart.nets.hill_nets import HillNets, load_nets

SHIPPED = load_nets(FRANCIS_DIR / "nets.json")


def test_shipped_file_has_an_ensemble_and_round_trips_exactly(tmp_path):
    assert len(SHIPPED.ensemble) == 10
    again = HillNets.from_json(SHIPPED.to_json())
    assert again.to_json() == SHIPPED.to_json()
    assert all(a[0] == b[0] and a[1] == b[1] for a, b in zip(again.ensemble, SHIPPED.ensemble))


def test_a_file_without_ensemble_is_the_version_1_file_of_before(tmp_path):
    doc = json.loads(SHIPPED.to_json())
    del doc["ensemble"]
    nets = HillNets.from_dict(doc)
    assert nets.ensemble == [] and "ensemble" not in nets.to_dict()
    assert float(nets.q11(67.8, 23.46)) == float(SHIPPED.q11(67.8, 23.46))  # the point estimate is unchanged
    with pytest.raises(InputError, match="no ensemble"):
        nets.band("q11", 67.8, 23.46)


@pytest.mark.parametrize("ensemble,message", [({"flow": 1}, "ensemble must be a list"),
                                              ([{"flow": None}], r"ensemble\[0\] must be an object with the keys"),
                                              ([{"flow": None, "torque": None, "x": 1}], r"ensemble\[0\]"),
                                              ([{"flow": "NET", "torque": "NET"}], r"ensemble\[0\].flow must be")])
def test_malformed_ensemble_is_rejected(ensemble, message):
    doc = json.loads(SHIPPED.to_json())
    doc["ensemble"] = ensemble
    with pytest.raises(InputError, match=message):
        HillNets.from_dict(doc)


def test_band_is_the_spread_of_the_members():
    n11, a = np.array([50.0, 67.8, 85.0]), np.array([14.0, 23.46, 30.0])
    band = SHIPPED.band("q11", n11, a)
    values = np.array([m.q11(n11, a) for m in SHIPPED.members()])
    np.testing.assert_allclose(band["mean"], values.mean(axis=0), rtol=1e-14)
    np.testing.assert_allclose(band["low"], np.percentile(values, 5, axis=0), rtol=1e-14)
    assert np.all(band["low"] <= band["mean"]) and np.all(band["mean"] <= band["high"])
    eta = SHIPPED.band("efficiency", n11, a)
    assert np.all((eta["low"] > 0.78) & (eta["high"] < 0.95))  # digitized region: contours 0.80-0.938 (85, 30: 0.80)
    with pytest.raises(InputError, match="quantity"):
        SHIPPED.band("power", n11, a)
    with pytest.raises(InputError, match="percentiles"):
        SHIPPED.band("q11", n11, a, percentiles=(95, 5))


def test_six_coefficient_band_brackets_the_members():
    band = six_coefficients_band(SHIPPED, n11=67.8, opening=23.46)
    for j, name in enumerate(COEFFICIENT_NAMES):
        member_values = [six_coefficients(m, n11=67.8, opening=23.46).as_tuple()[j] for m in SHIPPED.members()]
        assert band[name]["low"] <= np.median(member_values) <= band[name]["high"]
        assert band[name]["low"] >= min(member_values) and band[name]["high"] <= max(member_values)


def _write(tmp_path, text: bytes | str):
    path = tmp_path / "nets.json"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
    return path


def test_non_utf8_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        load_nets(_write(tmp_path, b"\xff\xfe{\x00"))


def test_huge_integer_is_an_input_error(tmp_path):
    doc = json.loads(SHIPPED.to_json())
    text = json.dumps(doc).replace(json.dumps(doc["flow"]["b2"]), "1" + "0" * 399, 1)
    with pytest.raises(InputError, match=r"flow.b2 must be a number of magnitude"):
        load_nets(_write(tmp_path, text))
    text = json.dumps(doc).replace(json.dumps(doc["flow"]["b2"]), "1" * 5000, 1)  # beyond int-str limit
    with pytest.raises(InputError, match="not a valid nets file"):
        load_nets(_write(tmp_path, text))


def test_deep_nesting_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="nested too deeply"):
        load_nets(_write(tmp_path, "[" * 100000 + "]" * 100000))


@pytest.mark.parametrize("key,value", [("y_min", -1e300), ("y_max", 1e300), ("W2", [1e300] * 4)])
def test_values_that_would_overflow_are_rejected(tmp_path, key, value):
    doc = json.loads(SHIPPED.to_json())
    if key == "W2":
        value = [1e300] * len(doc["flow"]["W2"])
    doc["flow"][key] = value
    with pytest.raises(InputError, match=rf"flow.{key}(\[0\])? must have magnitude <= 1e\+09"):
        load_nets(_write(tmp_path, json.dumps(doc)))


def test_folder_and_byte_order_mark(tmp_path):
    with pytest.raises(InputError, match="is a folder"):
        load_nets(tmp_path)
    nets = load_nets(_write(tmp_path, b"\xef\xbb\xbf" + SHIPPED.to_json().encode("utf-8")))
    assert nets.flow == SHIPPED.flow


@pytest.mark.slow
def test_trust_map_is_wider_outside_the_digitized_region(tmp_path):
    from hillchart.nets import chartplot
    from hillchart.io.samples import measured_region_mask
    from hillchart.io.samples import load_chart

    chart = load_chart(FRANCIS_DIR)
    N, A, width = chartplot.trust_map(SHIPPED, grid=41)
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, N, A)
    # measured: median band width 0.24 % of the range inside, 0.50 % outside where the nets alone answer (above the
    # lowest line; below it the members' draws of the physical model give 0.19 %): the map shows where data end
    nets_alone = ~inside & (A >= SHIPPED.silent_model.blend_openings[1])
    assert np.all(width >= 0) and np.median(width[nets_alone]) > 1.5 * np.median(width[inside])
    fig = chartplot.chart_figure(SHIPPED, samples=chart, path=tmp_path / "c.png")
    assert any("trust map" in ax.get_title() for ax in fig.axes)
    single = HillNets(flow=SHIPPED.flow, torque=SHIPPED.torque, opening_unit="mm")
    fig2 = chartplot.chart_figure(single, samples=chart)
    assert not any("trust map" in ax.get_title() for ax in fig2.axes)  # no ensemble, no map
