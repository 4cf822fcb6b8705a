"""``hillsim four-quadrant``: a pump-turbine's complete characteristics to the Suter-curve nets a plant runs, the band
calibrated on the table's own lines; bounded options, nothing written on any error."""

import shutil

import numpy as np
import pytest

from data_synthetic import PUMP_TURBINE_DIR
from hillchart.four_quadrant import nets as suter_nets
from hillchart.four_quadrant.nets import load_suter_nets
from hillsim.cli import main
from hillsim.commands import four_quadrant


@pytest.fixture
def table(tmp_path):
    folder = tmp_path / "table"
    folder.mkdir()
    for name in ("table.toml", "table.csv"):
        shutil.copy(PUMP_TURBINE_DIR / name, folder / name)
    return folder


@pytest.mark.parametrize("argv,message", [
    (["--hidden", "1"], "--hidden must be an integer in [2, 60], got 1"),
    (["--members", "0"], "--members must be an integer in [1, 20], got 0"),
    (["--seed", "-1"], "--seed must be an integer in [0, 2147483647], got -1"),
])
def test_bad_options_exit_2_and_write_nothing(table, tmp_path, capsys, argv, message):
    out = tmp_path / "nets.json"
    assert main(["four-quadrant", str(table), "--out", str(out)] + argv) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_table_file_as_output_and_a_table_of_curves_are_refused(table, capsys):
    before = (table / "table.csv").read_bytes()
    assert main(["four-quadrant", str(table), "--out", str(table / "table.csv")]) == 2
    assert "is the input" in capsys.readouterr().err and (table / "table.csv").read_bytes() == before
    (table / "table.toml").write_text('name = "c"\nopening_unit = "mm"\nopening_max = 28\nsuter_convention = '
                                      '"turbine"\nsuter_k1 = 0\nsuter_k2 = 0\nsuter_c_h = 0\nsuter_c_y = 0\n')
    (table / "table.csv").write_text("opening,x,wh,wm\n" + "".join(f"{a},{x},0.5,0.4\n" for a in (4, 8, 12, 16)
                                                                     for x in (0.5, 1.5, 2.5, 3.5)))
    assert main(["four-quadrant", str(table), "--out", str(table.parent / "n.json")]) == 2
    assert "a table of Suter curves has no rated point for the simulator" in capsys.readouterr().err
    assert not (table.parent / "n.json").exists()


def test_the_defaults_are_the_shipped_nets(table, tmp_path, capsys):
    """The command's defaults are the shipped nets' (what ``python -m hillchart.four_quadrant.nets`` writes): on the
    shipped table, small nets of two members train in seconds and the band is calibrated; without calibration the
    command warns that the band is the training spread."""
    assert four_quadrant.SHIPPED == {k: suter_nets.SHIPPED[k] for k in ("hidden", "members", "seed")}
    out = tmp_path / "nets.json"
    assert main(["four-quadrant", str(table), "--out", str(out), "--hidden", "6", "--members", "2"]) == 0
    printed = capsys.readouterr().out
    nets = load_suter_nets(out)
    assert nets.training["rated"]["n11_rpm"] == pytest.approx(73.6894) and nets.training["opening_max"] == 28
    assert nets.training["band"]["calibrated"] and "band: calibrated on the table's own lines" in printed
    assert nets.wh.hidden == 6 and len(nets.members) == 2 and nets.members[1][0].hidden == 12  # point + member
    wh, _ = nets.curves(np.array([3.0]), np.array([0.5]))
    assert np.isfinite(wh).all()
    assert main(["four-quadrant", str(table), "--out", str(out), "--hidden", "6", "--members", "2",
                 "--no-calibration"]) == 0
    assert "warning: band not calibrated (--no-calibration)" in capsys.readouterr().out
    assert "band" not in load_suter_nets(out).training
