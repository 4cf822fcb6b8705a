"""Complete-characteristics tables and the Wylie-Streeter pump curves: reading, the Suter samples, bad input."""

import math
import shutil

import numpy as np
import pytest

from data_synthetic import PUMP_TURBINE_DIR
from hillchart.errors import InputError
from hillchart.four_quadrant.suter import PLAIN, SuterConstants, zone
from hillchart.four_quadrant.table import load_complete_characteristics, load_wylie_streeter_curves
from tests.external_charts import require_external

IMPROVED = SuterConstants(k1=6.5, k2=0.5, c_h=0.5, c_y=0.2)


def test_the_shipped_table_covers_all_four_quadrants():
    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    assert table.opening.size == 652 and np.unique(table.opening).size == 13
    rel = table.relative()
    names = set(zone(rel["speed"], rel["flow"], rel["torque"]))
    assert names == {"turbine", "turbine brake", "reverse pump", "pump", "pump brake"}
    # the rated point is a turbine point of the table's machine: v = q = m = 1 there
    assert table.rated["q11_m3_s"] == pytest.approx(0.194059)


def test_a_table_of_curves_reads_back_what_was_written(tmp_path):
    """The improved curves of the shipped table written as opening,x,wh,wm: read back to the digits written (1e-12
    with 17 significant digits), and refused when asked for other constants."""
    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    s = table.suter(IMPROVED)
    folder = tmp_path / "curves"
    folder.mkdir()
    rows = "\n".join(f"{a:.17g},{x:.17g},{wh:.17g},{wm:.17g}" for a, x, wh, wm in
                     zip(table.opening, s["x"], s["wh"], s["wm"]))
    (folder / "table.csv").write_text("opening,x,wh,wm\n" + rows + "\n")
    (folder / "table.toml").write_text('name = "curves"\nopening_unit = "mm"\nopening_max = 28\n'
                                       'suter_convention = "turbine"\nsuter_k1 = 6.5\nsuter_k2 = 0.5\n'
                                       'suter_c_h = 0.5\nsuter_c_y = 0.2\n')
    curves = load_complete_characteristics(folder)
    back = curves.suter(IMPROVED)
    for key in ("x", "opening", "wh", "wm"):
        assert np.max(np.abs(back[key] - s[key])) < 1e-12, key
    with pytest.raises(InputError, match="cannot be re-transformed"):
        curves.suter(PLAIN)
    with pytest.raises(InputError, match="no unit quantities"):
        curves.relative()


def _folder(tmp_path, toml=None, csv=None):
    folder = tmp_path / "t"
    shutil.copytree(PUMP_TURBINE_DIR, folder, ignore=shutil.ignore_patterns("nets.json"))
    if toml is not None:
        (folder / "table.toml").write_text(toml((folder / "table.toml").read_text()))
    if csv is not None:
        (folder / "table.csv").write_text(csv((folder / "table.csv").read_text()))
    return folder


def _replace_row(line_no, new):
    def edit(text):
        lines = text.splitlines()
        lines[line_no - 1] = new
        return "\n".join(lines) + "\n"
    return edit


@pytest.mark.parametrize("toml, csv, message", [
    (lambda t: t.replace("rated_q11 = 0.194059\n", ""), None, r"missing key\(s\) \['rated_q11'\]"),
    (lambda t: t + "rated_speed = 1\n", None, r"unknown key\(s\) \['rated_speed'\]"),
    (lambda t: t.replace('opening_unit = "mm"', 'opening_unit = "inch"'), None,
     r"opening_unit must be one of \('mm', 'deg', '%'\), got 'inch'"),
    (lambda t: t.replace("rated_m11_nm = 229.4721", "rated_m11_nm = -229.4721"), None,
     r"rated_m11_nm must be a finite number > 0, got -229.4721"),
    (lambda t: t + "suter_k1 = 1.0\n", None, r"key\(s\) \['suter_k1'\] belong to a table with columns opening,x,wh,wm"),
    (lambda t: t.replace('q11_unit = "m3/s"', 'q11_unit = "m3/h"'), None,
     r"q11_unit must be one of \('m3/s', 'l/s'\), got 'm3/h'"),
    (None, _replace_row(2, "29,-69.86,-0.0089,24.3"),
     r"row 2, column 'opening': 29.0 is outside \(0, opening_max = 28\]"),
    (None, _replace_row(2, "0,-69.86,-0.0089,24.3"), r"row 2, column 'opening': 0.0 is outside"),
    (None, _replace_row(2, "4,-1500,-0.0089,24.3"), r"row 2, column 'n11': -1500.0 is outside \[-1000, 1000\] r/min"),
    (None, _replace_row(2, "4,0,0,24.3"), r"row 2, column 'q11': 0.0 is outside the plane without the origin"),
    (None, _replace_row(2, "4,abc,-0.0089,24.3"), r"row 2, column 'n11': not a number: 'abc'"),
    (None, lambda t: t + "27,1,0.1,1\n27,2,0.1,1\n", r"opening line\(s\) at \[27.0\] have fewer than 3 points"),
])
def test_bad_tables_are_refused_with_file_row_and_column(tmp_path, toml, csv, message):
    with pytest.raises(InputError, match=message):
        load_complete_characteristics(_folder(tmp_path, toml, csv))


def test_a_missing_file_or_folder_is_named(tmp_path):
    with pytest.raises(InputError, match="not a complete-characteristics folder"):
        load_complete_characteristics(tmp_path / "nowhere")
    folder = _folder(tmp_path)
    (folder / "table.csv").unlink()
    with pytest.raises(InputError, match=r"table.csv: missing file"):
        load_complete_characteristics(folder)


@pytest.mark.external
def test_wylie_streeter_curves_read_as_the_book_draws_them():
    """Three pumps of 89 points over [0, 2 pi]; the radial pump's shutoff head at rated speed (x = pi) is 1.288, and
    its rated pump point (alpha = v = 1, x = 5 pi/4) has WH and WB near 1/2 (linear interpolation of the
    table: within 0.02, the change of WH over one 4.1 deg step there)."""
    folder = require_external("suter_wylie1993_fig7-2.csv")
    pumps = load_wylie_streeter_curves(folder / "suter_wylie1993_fig7-2.csv")
    assert list(pumps) == ["radial", "mixed", "axial"]
    assert [p.specific_speed for p in pumps.values()] == [25.0, 147.0, 261.0]
    radial = pumps["radial"]
    assert radial.x.size == 89 and radial.x[-1] == pytest.approx(2 * math.pi)
    assert float(np.interp(math.pi, radial.x, radial.wh)) == pytest.approx(1.288, abs=1e-9)
    assert float(np.interp(1.25 * math.pi, radial.x, radial.wh)) == pytest.approx(0.5, abs=0.02)
    assert float(np.interp(1.25 * math.pi, radial.x, radial.wb)) == pytest.approx(0.5, abs=0.02)


@pytest.mark.parametrize("text, message", [
    ("x_rad,WH_Ns25_radial,WB_Ns25_radial\n0,1,1\n", r"missing column 'x_deg'"),
    ("x_rad,x_deg,WH_Ns25_radial\n0,0,1\n1,57.3,1\n", r"column 'WH_Ns25_radial' has no partner 'WB_Ns25_radial'"),
    ("x_rad,x_deg,WH_radial,WB_radial\n0,0,1,1\n", r"column 'WH_radial' is not WH_Ns<N>_<name>"),
    ("x_rad,x_deg,WH_Ns25_r,WB_Ns25_r\n1,57.3,1,1\n0.5,28.6,1,1\n", r"x_rad' must ascend within \[0, 2 pi\]"),
    ("x_rad,x_deg,WH_Ns25_r,WB_Ns25_r\n0,0,1,1\n1,50,1,1\n", r"row 3: x_deg = 50.0 is not x_rad = 1.0 in degrees"),
])
def test_bad_pump_curve_files_are_refused(tmp_path, text, message):
    path = tmp_path / "curves.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        load_wylie_streeter_curves(path)
