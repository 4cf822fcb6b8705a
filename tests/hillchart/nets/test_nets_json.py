"""nets.json: exact round trip and rejection of every malformed case (one test each, message names the key)."""

import copy
import json

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.nets.hill_nets import HillNets, load_nets
from hillchart.nets.weights import NetWeights


def make_nets(hidden=5):
    rng = np.random.default_rng(42)

    def weights(y_min, y_max):
        # values with long decimal expansions so that any lossy float formatting would show
        return NetWeights(x_min=[0.0, 0.0], x_max=[152.3456789, 32.1], y_min=y_min, y_max=y_max,
                          W1=rng.normal(0, 3, (hidden, 2)), b1=rng.normal(0, 1, hidden), W2=rng.normal(0, 1, hidden),
                          b2=float(rng.normal()) / 3)

    return HillNets(flow=weights(0.0, 0.61234), torque=weights(-412.5, 987.25), opening_unit="mm",
                    training={"seed": 0, "flow": {"epochs": 12}})


@pytest.fixture
def doc():
    return make_nets().to_dict()


def test_round_trip_is_exact(tmp_path):
    nets = make_nets()
    path = nets.save(tmp_path / "nets.json")
    back = load_nets(path)
    assert back.flow == nets.flow and back.torque == nets.torque  # bit-identical weights and ranges
    assert back.opening_unit == "mm" and back.training == nets.training
    assert back.to_json() == nets.to_json()  # and the text regenerates byte for byte
    rng = np.random.default_rng(0)
    n11, a = rng.uniform(0, 150, 20), rng.uniform(0, 32, 20)
    np.testing.assert_array_equal(back.m11(n11, a), nets.m11(n11, a))


def test_file_has_the_documented_shape(doc):
    assert doc["format"] == "hillsim.nets" and doc["version"] == 1
    assert doc["units"] == {"n11": "r/min", "opening": "mm", "q11": "m^3/s", "m11": "N*m"}
    net = doc["flow"]
    assert net["inputs"] == ["n11", "opening"] and net["output"] == "q11" and doc["torque"]["output"] == "m11"
    assert len(net["W1"]) == 5 and all(len(row) == 2 for row in net["W1"])
    assert len(net["b1"]) == 5 and len(net["W2"]) == 5 and isinstance(net["b2"], float)


def test_extra_keys_are_allowed(doc):
    doc["comment"] = "made by hand"
    doc["flow"]["note"] = 1
    assert HillNets.from_dict(doc).flow == make_nets().flow


def test_missing_training_is_allowed(doc):
    del doc["training"]
    assert HillNets.from_dict(doc).training == {}


def mutate(doc, path, value):
    d = copy.deepcopy(doc)
    target = d
    for key in path[:-1]:
        target = target[key]
    if value is DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return d


DELETE = object()

CASES = {
    "wrong format": (("format",), "hillsim.other", r"format must be 'hillsim.nets'"),
    "wrong version": (("version",), 2, r"version must be 1, got 2"),
    "version as bool": (("version",), True, r"version must be 1"),
    "missing flow": (("flow",), DELETE, r"key 'flow' is missing"),
    "missing units": (("units",), DELETE, r"key 'units' is missing"),
    "wrong q11 unit": (("units", "q11"), "l/s", r"units.q11 must be 'm\^3/s', got 'l/s'"),
    "wrong m11 unit": (("units", "m11"), "kN*m", r"units.m11 must be 'N\*m'"),
    "missing opening unit": (("units", "opening"), DELETE, r"units.opening must be"),
    "flow not object": (("flow",), [1, 2], r"flow must be an object"),
    "missing b2": (("torque", "b2"), DELETE, r"torque.b2 is missing"),
    "wrong inputs": (("flow", "inputs"), ["opening", "n11"], r"flow.inputs must be"),
    "swapped output": (("flow", "output"), "m11", r"flow.output must be 'q11'"),
    "W1 row too short": (("flow", "W1", 2), [0.5], r"flow.W1\[2\] must have 2 entries"),
    "W1 empty": (("flow", "W1"), [], r"flow.W1 must be a non-empty list"),
    "b1 wrong length": (("flow", "b1"), [0.1, 0.2], r"flow.b1 must have 5 entries, got 2"),
    "W2 wrong length": (("torque", "W2"), [0.1] * 6, r"torque.W2 must have 5 entries, got 6"),
    "x_min wrong length": (("flow", "x_min"), [0.0], r"flow.x_min must have 2 entries"),
    "x_max <= x_min": (("flow", "x_max"), [152.0, 0.0], r"flow.x_max\[1\] \(opening\) must be > flow.x_min\[1\]"),
    "y_max <= y_min": (("torque", "y_max"), -500.0, r"torque.y_max must be > torque.y_min"),
    "string weight": (("flow", "b1", 0), "0.3", r"flow.b1\[0\] must be a number"),
    "bool weight": (("flow", "b2"), False, r"flow.b2 must be a number"),
    "null weight": (("torque", "W2", 4), None, r"torque.W2\[4\] must be a number"),
    "training not object": (("training",), [1], r"training must be an object"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_document_is_rejected(doc, tmp_path, case):
    path_keys, value, match = CASES[case]
    bad = mutate(doc, path_keys, value)
    path = tmp_path / "nets.json"
    path.write_text(json.dumps(bad))
    with pytest.raises(InputError, match=match) as info:
        load_nets(path)
    assert str(path) in str(info.value)  # the message also names the file


@pytest.mark.parametrize("literal, key", [("NaN", "b2"), ("Infinity", "b2"), ("-Infinity", "y_min"),
                                          ("1e400", "y_max")])
def test_nan_and_infinity_are_rejected(doc, tmp_path, literal, key):
    text = json.dumps(doc)
    original = json.dumps(doc["flow"][key])
    text = text.replace(f'"{key}": {original}', f'"{key}": {literal}', 1)
    assert literal in text
    path = tmp_path / "nets.json"
    path.write_text(text)
    with pytest.raises(InputError, match=f"flow.{key} must be finite, got (nan|inf|-inf)"):
        load_nets(path)


def test_invalid_json_is_rejected(tmp_path):
    path = tmp_path / "nets.json"
    path.write_text('{"format": "hillsim.nets", ')
    with pytest.raises(InputError, match="not valid JSON"):
        load_nets(path)


def test_top_level_not_object_is_rejected(tmp_path):
    path = tmp_path / "nets.json"
    path.write_text("[1, 2, 3]")
    with pytest.raises(InputError, match="must hold an object, got list"):
        load_nets(path)


def test_missing_file_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_nets(tmp_path / "absent.json")


def test_netweights_constructor_validates():
    with pytest.raises(InputError, match=r"x_max\[0\] \(n11\) must be >"):
        NetWeights(x_min=[5.0, 0.0], x_max=[5.0, 1.0], y_min=0.0, y_max=1.0, W1=[[1.0, 1.0]], b1=[0.0], W2=[1.0],
                   b2=0.0)
    with pytest.raises(InputError, match=r"W1\[0\]\[1\] must be finite"):
        NetWeights(x_min=[0.0, 0.0], x_max=[5.0, 1.0], y_min=0.0, y_max=1.0, W1=[[1.0, np.nan]], b1=[0.0],
                   W2=[1.0], b2=0.0)
