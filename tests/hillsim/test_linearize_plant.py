"""``hillsim linearize NETS --plant plant.toml``: the linear model at a plant's initial operating point."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hillsim.cli import main

pytest.importorskip("simulate.loop.engine")

from data_synthetic import FRANCIS_DIR  # noqa: E402
from hillchart.linearize import six_coefficients  # noqa: E402
from hillchart.nets.hill_nets import load_nets  # noqa: E402

PLANT_FILE = FRANCIS_DIR.parent / "plant_hla339.toml"
NETS = FRANCIS_DIR / "nets.json"


@pytest.mark.parametrize("model, order", [("rigid", 2), ("lumped", 3)])
def test_linearize_at_plant_operating_point(capsys, model, order):
    assert main(["linearize", str(NETS), "--plant", str(PLANT_FILE), "--stroke", "0.68", "--penstock-model",
                 model]) == 0
    out = json.loads(capsys.readouterr().out)
    op = out["operating_point"]
    assert op["stroke"] == 0.68 and op["n11_rpm"] == pytest.approx(200 * 4.5 / np.sqrt(op["head_m"]), rel=1e-12)
    ref = six_coefficients(load_nets(NETS), n11=op["n11_rpm"], opening=op["opening_chart"])
    assert out["coefficients"]["ex"] == pytest.approx(ref.ex, rel=1e-12)
    lin = out["linear_model"]
    eig = np.sort([complex(*v) for v in lin["eigenvalues"]])
    np.testing.assert_allclose(eig, np.sort(np.roots(lin["speed_tf"]["den"])), rtol=1e-9)  # poles of N/D = eig(A)
    assert lin["open_loop_stable"] and len(lin["arx"]["a"]) == order
    # Tw at O from the penstock geometry: sum L/(g A) * Q0 / H0 (two segments of the shipped plant)
    inertance = sum(length / (9.81 * np.pi * d**2 / 4) for length, d in ((320.0, 6.2), (180.0, 5.6)))
    assert lin["water_time_s"] == pytest.approx(inertance * op["flow_m3_s"] / op["head_m"], rel=1e-12)
    # the printed JSON is the typed record plant_linearization returns (one JSON function for both)
    from simulate.config import load_plant
    from simulate.identification.results import to_json_dict
    from simulate.identification.linear_reference import plant_linearization

    record = plant_linearization(load_plant(PLANT_FILE), load_nets(NETS), initial_opening=0.68, penstock_model=model)
    assert record.linear_model.arx.a == tuple(lin["arx"]["a"]) and record.operating_point.stroke == 0.68
    assert {k: v for k, v in out.items() if k not in ("source", "opening_unit", "plant")} == to_json_dict(record)


def test_linearize_set_overrides_the_plant_as_run_does(capsys):
    """--set of hillsim run: the plant's key changed before its operating point is found (200 MW at 170 m static
    head here), the same linear model as the plant file with those keys."""
    from simulate.config import load_plant
    from simulate.identification.results import to_json_dict
    from simulate.identification.linear_reference import plant_linearization

    sets = ["--set", "penstock.static_head_m=170", "--set", "scenario.initial_power_mw=200"]
    assert main(["linearize", str(NETS), "--plant", str(PLANT_FILE), *sets]) == 0
    out = json.loads(capsys.readouterr().out)
    plant = load_plant(PLANT_FILE, {"penstock.static_head_m": 170, "scenario.initial_power_mw": 200})
    record = to_json_dict(plant_linearization(plant, load_nets(NETS)))
    assert {k: v for k, v in out.items() if k not in ("source", "opening_unit", "plant")} == record
    assert out["operating_point"]["power_mw"] == pytest.approx(200.0, rel=1e-12)
    assert out["operating_point"]["head_m"] < 170.0  # the lower reservoir, less the losses (225 MW: above 170 m)
    assert main(["linearize", str(NETS), "--plant", str(PLANT_FILE)]) == 0
    assert json.loads(capsys.readouterr().out)["operating_point"]["head_m"] > 170.0


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--set", "governor.kp=3"], "--set 'governor.kp=3' needs --plant: it overrides a key of the plant file"),
        (["--plant", str(PLANT_FILE), "--set", "penstock.static_head_m=-5"],
         "penstock.static_head_m must be"),
        (["--plant", str(PLANT_FILE), "--set", "penstock.static_hed_m=170"],
         "unknown key penstock.static_hed_m; valid keys of [penstock]"),
        (["--plant", str(PLANT_FILE), "--set", "static_head_m"], "--set expects section.key=value"),
        (["--stroke", "0.5"], "--stroke and --penstock-model need --plant"),
        (["--plant", str(PLANT_FILE), "--n11", "67"], "with --plant the operating point comes from the plant"),
        (["--plant", str(PLANT_FILE), "--stroke", "0.68", "--tau", "-1"], "--tau must be > 0"),
    ],
)
def test_linearize_plant_bad_options(argv, message, capsys):
    assert main(["linearize", str(NETS), *argv]) == 2
    assert message in capsys.readouterr().err


def test_nets_of_the_other_kind_than_the_plant_are_named_as_nets(capsys):
    """NETS stands in for the plant's characteristics: a mismatch names NETS (the message named the plant's own
    turbine.characteristics, which were right)."""
    from data_synthetic import BULB_DIR, PLANT_BULB

    assert main(["linearize", str(FRANCIS_DIR / "nets.json"), "--plant", str(PLANT_BULB)]) == 2
    err = capsys.readouterr().err
    assert "nets.json' has two inputs, but the plant is double-regulated" in err
    assert "e.g. the plant's own turbine.characteristics = 'bulb/nets.json'" in err
    assert main(["linearize", str(BULB_DIR / "nets.json"), "--plant", str(PLANT_FILE)]) == 2
    assert "has three inputs (a blade angle), but the plant has no [combinator]" in capsys.readouterr().err
    # each kind with its own plant: the coefficients
    assert main(["linearize", str(BULB_DIR / "nets.json"), "--plant", str(PLANT_BULB)]) == 0
    assert set(json.loads(capsys.readouterr().out)["coefficients"]) >= {"ex", "ey", "eh", "eqx", "eqy", "eqh"}
