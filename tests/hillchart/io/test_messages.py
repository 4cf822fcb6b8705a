"""Input messages: byte-order marks, semicolon/tab files, one row convention, no numpy reprs, rows named."""

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.io.samples import load_chart
from hillchart.io.tabular import read_table
from simulate.identification.measured import MEASURED_COLUMNS, OperatingPoint, RelativeSeries, load_measured_series
from simulate.config import load_plant

REPO = Path(__file__).resolve().parents[3]
FRANCIS = REPO / "data_synthetic" / "francis"
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"


@pytest.fixture()
def chart_copy(tmp_path):
    folder = tmp_path / "chart"
    folder.mkdir()
    for name in ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv"):
        shutil.copy(FRANCIS / name, folder / name)
    return folder


def _reference_chart():
    return load_chart(FRANCIS)


def test_byte_order_mark_is_accepted_in_chart_csv_and_toml(chart_copy):
    for name in ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv"):
        path = chart_copy / name
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())  # what Excel's "CSV UTF-8" writes
    chart = load_chart(chart_copy)
    ref = _reference_chart()
    np.testing.assert_array_equal(chart.flow_q11, ref.flow_q11)
    np.testing.assert_array_equal(chart.eff_efficiency, ref.eff_efficiency)


def test_comment_lines_are_allowed_in_chart_csvs_and_rows_keep_their_line_numbers(chart_copy):
    """A digitizer's notes as # lines (before the header, between rows) were refused as bad rows; they are comments,
    and a bad row below them is still named by its line in the file."""
    for name in ("flow.csv", "efficiency.csv", "runaway.csv"):
        path = chart_copy / name
        lines = path.read_text(encoding="utf-8").splitlines()
        path.write_text("\n".join(["# digitized from the manufacturer's chart", "  # second note", lines[0],
                                    "# the lowest line", *lines[1:]]) + "\n", encoding="utf-8")
    chart = load_chart(chart_copy)
    ref = _reference_chart()
    np.testing.assert_array_equal(chart.flow_q11, ref.flow_q11)
    np.testing.assert_array_equal(chart.eff_efficiency, ref.eff_efficiency)
    np.testing.assert_array_equal(chart.runaway_n11, ref.runaway_n11)
    assert chart.rows["flow"][0] == 5  # the first data row is line 5 of the file (2 notes, header, a note)
    path = chart_copy / "flow.csv"
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[6] = "10,abc,0.2"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"flow.csv: row 7, column 'n11'"):
        load_chart(chart_copy)


def test_byte_order_mark_is_accepted_in_the_plant_file(tmp_path):
    folder = tmp_path / "plant"
    shutil.copytree(REPO / "data_synthetic", folder, ignore=shutil.ignore_patterns("__pycache__"))
    path = folder / PLANT.name
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    with_bom, plain = load_plant(path), load_plant(PLANT)
    assert (with_bom.turbine, with_bom.penstock, with_bom.scenario) == (plain.turbine, plain.penstock, plain.scenario)


def _european(path: Path, delimiter: str, decimal_comma: bool) -> None:
    lines = path.read_text().splitlines()
    out = []
    for line in lines:
        cells = line.split(",")
        if decimal_comma:
            cells = [c.replace(".", ",") for c in cells]
        out.append(delimiter.join(cells))
    path.write_text("\n".join(out) + "\n")


@pytest.mark.parametrize("delimiter, decimal_comma, note", [
    (";", True, "semicolon-separated with decimal commas; read as such"),
    (";", False, "semicolon-separated; read as such"),
    ("\t", False, "tab-separated; read as such"),
    ("\t", True, "tab-separated with decimal commas; read as such"),
])
def test_semicolon_and_tab_files_are_read_and_the_choice_is_said(chart_copy, delimiter, decimal_comma, note):
    _european(chart_copy / "flow.csv", delimiter, decimal_comma)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chart = load_chart(chart_copy)
    assert any(note in str(w.message) and "flow.csv" in str(w.message) for w in caught)
    np.testing.assert_array_equal(chart.flow_n11, _reference_chart().flow_n11)


def test_a_spreadsheets_header_in_capitals_and_its_empty_trailing_column_are_read(chart_copy):
    """A spreadsheet's export: names capitalized and spaced ("Opening, N11 , Q11"), and a trailing comma on every
    line (a name-less column with no value). Read as the plain file (exactly the same points); refused before
    ("missing column(s)", then "unknown column(s) ['']"). A name-less column with a value is still refused, as are
    two names that differ only in case."""
    flow = chart_copy / "flow.csv"
    header, *rows = flow.read_text().splitlines()
    flow.write_text("\n".join(["Opening, N11 , Q11,"] + [row + "," for row in rows]) + "\n")
    chart, ref = load_chart(chart_copy), _reference_chart()
    for name in ("flow_opening", "flow_n11", "flow_q11"):
        np.testing.assert_array_equal(getattr(chart, name), getattr(ref, name))
    flow.write_text("\n".join(["opening,n11,q11,"] + [row + ",1" for row in rows]) + "\n")
    with pytest.raises(InputError, match=r"flow.csv: unknown column\(s\) \[''\]"):
        load_chart(chart_copy)
    flow.write_text("\n".join(["opening,n11,q11,Q11"] + [row + ",1" for row in rows]) + "\n")
    with pytest.raises(InputError, match=r"flow.csv: repeated column in header"):
        load_chart(chart_copy)


def test_plain_csv_gives_no_note(chart_copy):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped chart has runaway.csv: no warning at all
        load_chart(chart_copy)


def test_semicolon_file_with_mixed_separators_is_refused(chart_copy):
    path = chart_copy / "flow.csv"
    path.write_text("opening;n11;q11\n10;1.234,5;0,3\n")
    with pytest.raises(InputError, match=r"flow.csv: semicolon-separated, but the cell '1.234,5' holds both"):
        load_chart(chart_copy)


def test_one_row_convention_the_file_line(tmp_path):
    """A NaN and an empty cell on the same line report the same line (a NaN once reported 'row 300' where an
    empty cell on the same line reported 'line 302')."""
    rows = [",".join(MEASURED_COLUMNS)] + [f"{0.1 * i:.1f},200,176,0.68,1.1e7,142" for i in range(400)]
    rows.insert(5, "")  # a blank line: rows below it keep their file line numbers
    for cell, expected in (("nan", "value must be finite, got 'nan'"), ("", "not a number: ''")):
        lines = list(rows)
        cells = lines[301].split(",")
        cells[2] = cell
        lines[301] = ",".join(cells)  # file line 302
        path = tmp_path / "s.csv"
        path.write_text("\n".join(lines) + "\n")
        with pytest.raises(InputError, match=rf"s.csv: row 302, column 'head_m': {expected}"):
            load_measured_series(path, sample_time_s=0.2)


def test_time_not_increasing_names_the_row(tmp_path):
    lines = [",".join(MEASURED_COLUMNS)] + [f"{0.1 * i:.1f},200,176,0.68,1.1e7,142" for i in range(50)]
    lines[31] = lines[30]  # line 32 repeats the time of line 31
    path = tmp_path / "s.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"column 'time_s' must be strictly increasing: row 32 has 2.9 s after "
                                         r"2.9 s at row 31"):
        load_measured_series(path, sample_time_s=0.2)


def test_chart_row_numbers_are_file_lines(chart_copy):
    path = chart_copy / "flow.csv"
    lines = path.read_text().splitlines()
    lines[9] = lines[9].split(",")[0] + ",abc," + lines[9].split(",")[2]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"flow.csv: row 10, column 'n11': not a number: 'abc'"):
        load_chart(chart_copy)


def test_a_cell_with_an_underscore_is_refused_not_read_as_digit_grouping(chart_copy):
    """float('4_4.02') is 44.02 in Python: a chart cell written so is a typo and is refused naming file, line and
    cell; the same line without the underscore reads as 44.02."""
    path = chart_copy / "flow.csv"
    lines = path.read_text().splitlines()
    assert lines[1].split(",")[1] == "44.02"
    assert load_chart(chart_copy).flow_n11[0] == 44.02  # the plausible case: the cell as shipped
    lines[1] = lines[1].replace(",44.02,", ",4_4.02,")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"flow.csv: row 2, column 'n11': not a number: '4_4.02' \(an underscore"):
        load_chart(chart_copy)


def test_no_numpy_reprs_in_messages():
    """Messages show plain numbers, never numpy reprs such as 'got np.float64(0.0)'."""
    t = np.arange(20) * 0.1
    with pytest.raises(InputError) as exc:
        RelativeSeries.from_physical(t, 200 + 0 * t, 176 + 0 * t, 0.5 + 0 * t, 0 * t, 140 + 0 * t,
                                     sample_time_s=0.2)
    assert "got 0.0" in str(exc.value) and "np." not in str(exc.value)
    with pytest.raises(InputError) as exc:
        OperatingPoint(speed_rpm=np.float64(200), head_m=np.float64(-1.0), flow_m3_s=1.0, torque_nm=1.0, opening=1.0)
    assert str(exc.value).endswith("got -1.0")


def test_header_only_semicolon_hint(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("opening n11 q11\n1 2 3\n")
    with pytest.raises(InputError, match=r"missing column\(s\) \['opening', 'n11', 'q11'\]; the header must be "
                                         r"opening,n11,q11, got 'opening n11 q11'"):
        read_table(path, ("opening", "n11", "q11"))


def test_non_utf8_series_is_an_input_error(tmp_path):
    path = tmp_path / "s.csv"
    path.write_bytes(",".join(MEASURED_COLUMNS).encode() + b"\n0,\xff\xfe,1,1,1,1\n")
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        load_measured_series(path, sample_time_s=0.2)


def _with_blank_lines(path, edit):
    """Rewrite ``path`` with two blank lines after the header and one in the middle, then let ``edit`` change the
    list of file lines (index = line number - 1). Returns nothing; the file is rewritten in place."""
    lines = path.read_text().splitlines()
    lines = [lines[0], "", ""] + lines[1:20] + [""] + lines[20:]
    edit(lines)
    path.write_text("\n".join(lines) + "\n")


def test_chart_range_and_duplicate_messages_name_file_lines_below_blank_lines(chart_copy):
    """One row convention (the file's line number) in every chart message, blank lines counted. Line 30
    is below three blank lines: a convention counting data rows would say row 26 or 27."""
    path = chart_copy / "flow.csv"
    original = path.read_text()

    def negative_n11(lines):
        cells = lines[29].split(",")
        lines[29] = f"{cells[0]},-5,{cells[2]}"

    _with_blank_lines(path, negative_n11)
    with pytest.raises(InputError, match=r"flow.csv: row 30, column 'n11': -5.0 is out of range"):
        load_chart(chart_copy)

    path.write_text(original)

    def duplicate(lines):
        lines[29] = lines[27]  # file line 30 repeats file line 28

    _with_blank_lines(path, duplicate)
    with pytest.raises(InputError, match=r"flow.csv: duplicate point .* at rows \[28, 30\]"):
        load_chart(chart_copy)


def test_plausibility_messages_name_file_lines_below_blank_lines(chart_copy):
    """The outlier check reports the point by its file line, blank lines counted (line 30 is data row 27)."""
    from hillchart.extension.extend import extend_samples

    path = chart_copy / "flow.csv"

    def outlier(lines):
        cells = lines[29].split(",")
        lines[29] = f"{cells[0]},{cells[1]},{float(cells[2]) * 1.3:.4f}"  # 30 % off its opening line

    _with_blank_lines(path, outlier)
    chart = load_chart(chart_copy)
    with pytest.raises(InputError, match=r"flow.csv: row 30 \(opening"):
        extend_samples(chart)
