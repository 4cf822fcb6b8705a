"""``hillsim run`` on a plant with several units: per-unit columns, the manifold head, per-unit figures."""

import csv
import json

import numpy as np
import pytest

from data_synthetic import PLANT_TWO_UNITS
from hillsim.cli import main
from simulate.results.result import CSV_COLUMNS, UNIT_COLUMNS


@pytest.mark.slow
def test_run_on_a_two_unit_plant_writes_every_unit(tmp_path, capsys):
    out = tmp_path / "two"
    code = main(["run", str(PLANT_TWO_UNITS), "--out", str(out), "--no-plot", "--set",
                 "turbine.characteristics=\"ideal\"", "--set", "scenario.t_end_s=4"])
    assert code == 0
    assert "load-rejection" in capsys.readouterr().out
    with open(out / "timeseries.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    expected = (list(CSV_COLUMNS)  # then each branch's cavity volumes (the discrete vapour cavity model's columns)
                + [f"{u}.{c}" for u in ("U1", "U2") for c in ("cavity_volume_m3", "outlet_cavity_volume_m3")]
                + ["manifold_head_m", "manifold_flow_m3_s"]
                + [f"{u}.{c}" for u in ("U1", "U2") for c in UNIT_COLUMNS])
    assert header == expected
    data = np.array(rows[1:], dtype=float)
    col = {name: data[:, j] for j, name in enumerate(header)}
    # the plant-level series are the rejecting unit's (scenario.units = ["U1"])
    assert np.array_equal(col["speed_rpm"], col["U1.speed_rpm"])
    # the manifold passes both units' flow at the start (steady): 10 significant digits in the file
    assert col["manifold_flow_m3_s"][0] == pytest.approx(col["U1.flow_m3_s"][0] + col["U2.flow_m3_s"][0], rel=1e-9)
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["units"]) == {"U1", "U2"}
    assert summary["max_speed_rise"] == summary["units"]["U1"]["max_speed_rise"] > \
        summary["units"]["U2"]["max_speed_rise"] > 0.0
    assert summary["event_units"] == ["U1"]


@pytest.mark.parametrize("argv", [["identify", str(PLANT_TWO_UNITS)],
                                  ["linearize", "ideal", "--plant", str(PLANT_TWO_UNITS), "--stroke", "0.6"]])
def test_single_unit_commands_refuse_a_plant_with_units(argv, tmp_path, capsys):
    if argv[0] == "identify":
        argv = argv + ["--out", str(tmp_path / "ident")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "models a plant with one unit; this plant has [[units]] (U1, U2)" in err
    assert not (tmp_path / "ident").exists()  # nothing written


@pytest.mark.parametrize("characteristics", ["synthetic-bulb", "bulb/nets.json", "synthetic"])
def test_three_input_characteristics_on_units_without_a_combinator_are_refused(characteristics, tmp_path, capsys):
    """Double-regulated (blade-angle) characteristics on units without a [combinator] are refused naming the unit
    and the missing section (the same refusal as a plant of one unit); beside them, two-input synthetic Francis
    characteristics run."""
    out = tmp_path / "two"
    code = main(["run", str(PLANT_TWO_UNITS), "--out", str(out), "--no-plot", "--quiet", "--set",
                 f"turbine.characteristics={json.dumps(characteristics)}", "--set", "scenario.t_end_s=2.5"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if characteristics == "synthetic":
        assert code == 0 and (out / "summary.json").is_file()
        return
    assert code == 2 and not out.exists()
    assert err.strip().splitlines()[-1] == (
        f"hillsim run: error: unit 'U1': turbine.characteristics = '{characteristics}' has a blade angle (three "
        f"inputs): the plant needs a [combinator] section (relation = \"cam\", \"table\" or \"off\") and, unless "
        f"the blades are fixed, a [blade_servo] section")


def test_a_plant_with_units_written_for_the_workers_reads_back_equal():
    """The studies hand a plant to their workers as TOML (simulate.studies.cases.plant_toml)."""
    import tomllib
    from dataclasses import replace

    from simulate.config import plant_from_dict
    from simulate.studies.cases import plant_toml

    raw = tomllib.loads(PLANT_TWO_UNITS.read_text(encoding="utf-8"))
    raw["units"][1]["turbine"] = {"rated_power_mw": 200.0}
    raw["units"][1]["initial_power_mw"] = 150.0
    plant = plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)
    again = plant_from_dict(tomllib.loads(plant_toml(plant)), base_dir=plant.base_dir)
    absolute = again.turbine.characteristics
    assert absolute == str(PLANT_TWO_UNITS.parent / "francis" / "nets.json")
    back = [replace(u, turbine=replace(u.turbine, characteristics=plant.turbine.characteristics))
            for u in again.units]
    assert back == list(plant.units)
    assert again.units[1].turbine.rated_power_mw == 200.0 and again.units[1].initial_power_mw == 150.0
