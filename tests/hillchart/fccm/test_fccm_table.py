"""Test-table folders (table.csv + table.toml) of hillchart.fccm: derivation of n11/Q11 and garbage input."""

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.fccm.table import load_test_table

TOML = 'name = "rig"\nrunner_diameter_m = 0.5\nspeed_rpm = 600.0\ncontrols = ["blade_angle_deg", "guide_vane_deg"]\n'
CSV = ("blade_angle_deg,guide_vane_deg,efficiency,head_m,power_kw,flow_m3_s,comment\n"
       "-10,40,0.80,4.0,10.0,0.40,first\n"
       "0,50,0.90,9.0,20.0,0.50,\n"
       "# a comment line\n"
       "10,60,0.85,16.0,30.0,0.60,last\n")


def folder(tmp_path, csv_text=CSV, toml_text=TOML):
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "table.csv").write_text(csv_text, encoding="utf-8")
    (tmp_path / "table.toml").write_text(toml_text, encoding="utf-8")
    return tmp_path


def test_reads_columns_and_derives_unit_quantities(tmp_path):
    table = load_test_table(folder(tmp_path))
    assert table.n_rows == 3 and table.info.controls == ("blade_angle_deg", "guide_vane_deg")
    # eq. (2): n11 = n D / sqrt(H) = 600 * 0.5 / (2, 3, 4); eq. (1): Q11 = Q / (D^2 sqrt(H))
    np.testing.assert_allclose(table.column("n11_rpm"), [150.0, 100.0, 75.0], rtol=1e-15)
    np.testing.assert_allclose(table.column("q11_m3_s"), [0.4 / 0.5, 0.5 / 0.75, 0.6 / 1.0], rtol=1e-15)
    assert table.text_columns == ("comment",)
    with pytest.raises(InputError, match="'comment' .*not numeric"):
        table.column("comment")


def test_given_unit_columns_are_kept_and_speed_column_is_used(tmp_path):
    csv_text = "guide_vane_deg,head_m,speed_rpm,flow_m3_s,n11_rpm\n40,4,500,0.4,99\n50,9,600,0.5,98\n"
    toml_text = 'name = "x"\nrunner_diameter_m = 0.5\ncontrols = ["guide_vane_deg"]\n'
    table = load_test_table(folder(tmp_path, csv_text, toml_text))
    assert table.column("n11_rpm").tolist() == [99.0, 98.0] and table.derived == ("q11_m3_s",)
    csv_text = "guide_vane_deg,head_m,speed_rpm\n40,4,500\n50,9,600\n"
    table = load_test_table(folder(tmp_path, csv_text, toml_text))
    np.testing.assert_allclose(table.column("n11_rpm"), [125.0, 100.0])  # per-row speed


def test_without_diameter_there_is_no_derivation_and_the_error_says_why(tmp_path):
    toml_text = 'name = "x"\ncontrols = ["guide_vane_deg"]\n'
    table = load_test_table(folder(tmp_path, CSV, toml_text))
    with pytest.raises(InputError, match="no numeric column 'n11_rpm'.*runner_diameter_m"):
        table.column("n11_rpm")


@pytest.mark.parametrize("toml_text, message", [
    ('name = "x"\ncontrols = ["guide_vane_deg"]\nrunner_diameter = 1.0\n', r"unknown key\(s\) \['runner_diameter'\]"),
    ('controls = ["guide_vane_deg"]\n', r"missing required key\(s\) \['name'\]"),
    ('name = "x"\n', r"missing required key\(s\) \['controls'\]"),
    ('name = "x"\ncontrols = []\n', "controls must be a non-empty list"),
    ('name = "x"\ncontrols = "guide_vane_deg"\n', "controls must be a non-empty list"),
    ('name = "x"\ncontrols = ["guide_vane_deg", "guide_vane_deg"]\n', "controls must be distinct"),
    ('name = "x"\ncontrols = ["gv"]\n', "controls: 'gv' is not a numeric column"),
    ('name = "x"\ncontrols = ["comment"]\n', "controls: 'comment' is not a numeric column"),
    ('name = "x"\ncontrols = ["guide_vane_deg"]\nrunner_diameter_m = -1.0\n',
     "runner_diameter_m must be a finite number > 0, got -1.0"),
    ('name = "x"\ncontrols = ["guide_vane_deg"]\nspeed_rpm = "fast"\n', "speed_rpm must be a finite number > 0"),
    ('name = "x"\ncontrols = ["guide_vane_deg"]\nspeed_rpm = nan\n', "speed_rpm must be a finite number > 0"),
    ('name = ""\ncontrols = ["guide_vane_deg"]\n', "name must be a non-empty string"),
    ('name = "x\ncontrols = ["guide_vane_deg"]\n', "not valid TOML"),
])
def test_bad_toml(tmp_path, toml_text, message):
    with pytest.raises(InputError, match=message) as info:
        load_test_table(folder(tmp_path, CSV, toml_text))
    assert "table.toml" in str(info.value)  # the file is named


@pytest.mark.parametrize("csv_text, message", [
    ("", "empty file"),
    ("# only a comment\n", "empty file"),
    ("guide_vane_deg,head_m\n", "no data rows"),
    ("guide_vane_deg,,head_m\n40,,4\n", "row 1: empty column name"),
    ("guide_vane_deg,head_m,head_m\n40,4,4\n", r"row 1: repeated column name\(s\) \['head_m'\]"),
    ("guide_vane_deg,head_m\n40,4\n50\n", "row 3 has 1 fields, the header has 2"),
    ("guide_vane_deg,head_m\n40,4\n50,abc\n", "row 3, column 'head_m': not a number: 'abc'"),
    ("guide_vane_deg,head_m\n40,4\n50,inf\n", "row 3, column 'head_m': value must be finite"),
    ("guide_vane_deg,head_m\n40,4\n50,-2\n", "row 3, column 'head_m': -2.0 is out of range; allowed > 0 m"),
    ("guide_vane_deg,efficiency\n40,0.9\n# c\n50,91.5\n",
     r"row 4, column 'efficiency': 91.5 is out of range; allowed \[0, 1\] \(a fraction"),
    ("guide_vane_deg,flow_m3_s\n40,-0.1\n50,1\n", "row 2, column 'flow_m3_s'"),
    ("guide_vane_deg,speed_rpm\n40,0\n50,1\n", "row 2, column 'speed_rpm'"),
    ("guide_vane_deg,n11_rpm\n40,-3\n50,1\n", "row 2, column 'n11_rpm'"),
    ("guide_vane_deg,head_m\n40,4\n40,5\n", "column 'guide_vane_deg' \\(a control\\) is constant"),
    ("guide_vane_deg,head_m\n400,4\n40,5\n", "row 2, column 'guide_vane_deg': 400.0 is out of range"),
    ("guide_vane_deg,head_m\n40,\n50,5\n", "row 2, column 'head_m': not a number: ''"),
    ("guide_vane_deg,head_m\n40,4\n50,4_4.02\n", "row 3, column 'head_m': not a number: '4_4.02' \\(an underscore"),
])
def test_bad_csv(tmp_path, csv_text, message):
    toml_text = 'name = "x"\ncontrols = ["guide_vane_deg"]\nrunner_diameter_m = 1.0\n'
    with pytest.raises(InputError, match=message) as info:
        load_test_table(folder(tmp_path, csv_text, toml_text))
    assert "table.csv" in str(info.value)


def test_a_spreadsheets_capitalized_header_and_empty_trailing_column_read_as_the_csv(tmp_path):
    """Known columns named in capitals ("Blade_Angle_Deg") and a trailing comma on every line (a name-less column
    with no value) read as the plain table, exactly; refused before ("'blade_angle_deg' is not a numeric column",
    "empty column name in header"). An extra column keeps its own name; a name-less column with a value is still
    refused."""
    plain = load_test_table(folder(tmp_path / "plain"))
    header, *rows = CSV.splitlines()
    capitals = ",".join(name.title() if name != "comment" else "Comment" for name in header.split(","))
    text = "\n".join([capitals + ","] + [row + "," if not row.startswith("#") else row for row in rows]) + "\n"
    table = load_test_table(folder(tmp_path / "export", text))
    assert table.info.controls == plain.info.controls and table.text_columns == ("Comment",)
    for name in ("blade_angle_deg", "guide_vane_deg", "efficiency", "n11_rpm", "q11_m3_s"):
        np.testing.assert_array_equal(table.column(name), plain.column(name))
    text = "\n".join([header + ","] + [row + ",7" if not row.startswith("#") else row for row in rows]) + "\n"
    with pytest.raises(InputError, match="empty column name in header"):
        load_test_table(folder(tmp_path / "valued", text))


def test_speed_twice_and_missing_files(tmp_path):
    csv_text = "guide_vane_deg,head_m,speed_rpm\n40,4,500\n50,9,600\n"
    with pytest.raises(InputError, match="speed_rpm = 600.0 is given but .*also has a speed_rpm column"):
        load_test_table(folder(tmp_path, csv_text, TOML.replace('"blade_angle_deg", ', "")))
    with pytest.raises(InputError, match="no such directory"):
        load_test_table(tmp_path / "nowhere")
    (tmp_path / "t2").mkdir()
    (tmp_path / "t2" / "table.toml").write_text(TOML)
    with pytest.raises(InputError, match="table.csv: missing file"):
        load_test_table(tmp_path / "t2")
    (tmp_path / "t3").mkdir()
    (tmp_path / "t3" / "table.csv").write_text(CSV)
    with pytest.raises(InputError, match="table.toml: missing file"):
        load_test_table(tmp_path / "t3")
    (tmp_path / "t4").mkdir()
    (tmp_path / "t4" / "table.csv").write_bytes(b"guide_vane_deg\n\xff\xfe\n")
    (tmp_path / "t4" / "table.toml").write_text('name = "x"\ncontrols = ["guide_vane_deg"]\n')
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        load_test_table(tmp_path / "t4")


def _spreadsheet_export(csv_text: str, delimiter: str, decimal_comma: bool) -> str:
    """``csv_text`` as a spreadsheet in a decimal-comma locale saves it: another delimiter, commas for points."""
    lines = []
    for line in csv_text.splitlines():
        if line.startswith("#"):
            lines.append(line)
            continue
        cells = line.split(",")
        lines.append(delimiter.join(c.replace(".", ",") if decimal_comma else c for c in cells))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("delimiter, decimal_comma, note", [(";", True, "semicolon-separated with decimal commas"),
                                                            ("\t", False, "tab-separated; read as such")])
def test_a_spreadsheets_export_reads_as_the_csv(tmp_path, delimiter, decimal_comma, note):
    plain = load_test_table(folder(tmp_path / "plain"))
    exported = _spreadsheet_export(CSV, delimiter, decimal_comma)
    assert ("0,80" in exported) == decimal_comma
    with pytest.warns(UserWarning, match=note):
        table = load_test_table(folder(tmp_path / "export", "\ufeff" + exported))
    assert table.columns.keys() == plain.columns.keys() and table.text_columns == ("comment",)
    for name, values in plain.columns.items():
        assert np.array_equal(table.columns[name], values), name  # the same decimal strings: the same floats


def test_a_cell_with_a_comma_and_a_point_is_refused_in_a_semicolon_table(tmp_path):
    exported = _spreadsheet_export(CSV, ";", True).replace("0,80", "1.000,80")
    with pytest.raises(InputError, match=r"table.csv: semicolon-separated, but the cell '1.000,80' holds both a "
                                         r"comma and a point"):
        load_test_table(folder(tmp_path, exported))
    # a comma-separated table stays what it was: a semicolon inside a cell is no delimiter
    with pytest.raises(InputError, match=r"row 2, column 'efficiency': not a number: '0;8'"):
        load_test_table(folder(tmp_path, CSV.replace("0.80", "0;8")))
