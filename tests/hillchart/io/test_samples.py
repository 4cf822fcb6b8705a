"""The chart loader: unit normalization, and one test per rejection (each names file, row and column)."""

import shutil

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.errors import InputError
from hillchart.io.samples import load_chart

CHART_FILES = ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv")


@pytest.fixture
def chart_dir(tmp_path):
    for name in CHART_FILES:
        shutil.copy(FRANCIS_DIR / name, tmp_path / name)
    return tmp_path


def _replace(path, old, new, count=1):
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, count))


def test_loads_the_shipped_chart():
    chart = load_chart(FRANCIS_DIR)
    raw = np.loadtxt(FRANCIS_DIR / "flow.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(chart.flow_q11, raw[:, 2])  # m3/s chart: no scaling
    assert chart.info.runner_diameter_m == 0.35
    assert chart.openings.size == 12


def test_the_lines_points_load_in_their_natural_order_whatever_the_files_order(chart_dir):
    """Flow and runaway points come by opening and then N11 however the file lists them, so that the nets (whose
    cross-validation folds follow the points' order) depend on the points alone: the shipped chart's files written
    backwards load into the same arrays (exactly: only the order changes), and ``rows`` still gives each point's
    line in its file. The shipped chart is in that order already; written backwards and loaded as the file lists
    them, its first flow point would be the last line's (the assertion on ``flow_opening[0]`` fails)."""
    for name in ("flow.csv", "runaway.csv"):
        header, *points = (chart_dir / name).read_text().splitlines()
        (chart_dir / name).write_text("\n".join([header, *points[::-1]]) + "\n")
    chart, ref = load_chart(chart_dir), load_chart(FRANCIS_DIR)
    assert chart.flow_opening[0] == ref.openings[0]
    for field in ("flow_opening", "flow_n11", "flow_q11", "runaway_opening", "runaway_n11", "runaway_q11"):
        np.testing.assert_array_equal(getattr(chart, field), getattr(ref, field), err_msg=field)
    lines = (chart_dir / "flow.csv").read_text().splitlines()
    for i in (0, 7, chart.flow_n11.size - 1):
        opening, n11, q11 = (float(v) for v in lines[chart.rows["flow"][i] - 1].split(","))
        assert (opening, n11, q11) == (chart.flow_opening[i], chart.flow_n11[i], chart.flow_q11[i])


def test_litres_and_percent_are_normalized(chart_dir):
    _replace(chart_dir / "chart.toml", 'q11_unit = "m3/s"', 'q11_unit = "l/s"')
    _replace(chart_dir / "chart.toml", 'efficiency_unit = "fraction"', 'efficiency_unit = "percent"')
    for name in ("flow.csv", "efficiency.csv", "runaway.csv"):
        rows = [line.split(",") for line in (chart_dir / name).read_text().splitlines()]
        out = [",".join(rows[0])]
        for r in rows[1:]:
            first = f"{float(r[0]) * 100:.1f}" if name == "efficiency.csv" else r[0]
            out.append(",".join([first, r[1], f"{float(r[2]) * 1000:.1f}"]))
        (chart_dir / name).write_text("\n".join(out) + "\n")
    chart, ref = load_chart(chart_dir), load_chart(FRANCIS_DIR)
    np.testing.assert_allclose(chart.flow_q11, ref.flow_q11, rtol=1e-12)
    np.testing.assert_allclose(chart.eff_efficiency, ref.eff_efficiency, rtol=1e-12)
    np.testing.assert_allclose(chart.runaway_q11, ref.runaway_q11, rtol=1e-12)


def test_missing_runaway_warns(chart_dir):
    (chart_dir / "runaway.csv").unlink()
    with pytest.warns(UserWarning, match="runaway.csv is absent"):
        chart = load_chart(chart_dir)
    assert not chart.has_runaway


@pytest.mark.parametrize(
    "file,old,new,message",
    [
        ("chart.toml", 'opening_unit = "mm"', 'opening_unit = "inch"', r"opening_unit must be one of .* 'inch'"),
        ("chart.toml", 'q11_unit = "m3/s"', 'q11_unit = "cfs"', r"q11_unit must be one of .* 'cfs'"),
        ("chart.toml", 'efficiency_unit = "fraction"', 'efficiency_unit = "ratio"', r"efficiency_unit .* 'ratio'"),
        ("chart.toml", "opening_max = 32.0", "opening_max = -3.0",
         r"opening_max must be a finite number > 0, got -3.0"),
        ("chart.toml", "opening_max = 32.0", 'opening_max = "big"', r"opening_max must be a finite number > 0"),
        ("chart.toml", "runner_diameter_m = 0.35", "runner_diameter_m = 0.0", r"runner_diameter_m must be"),
        ("chart.toml", "runner_diameter_m = 0.35", "runner_diam = 0.35", r"unknown key\(s\) \['runner_diam'\]"),
        ("chart.toml", "opening_max = 32.0\n", "", r"missing required key\(s\) \['opening_max'\]"),
        ("chart.toml", "name =", "name = = ", r"not valid TOML"),
        ("flow.csv", "opening,n11,q11", "opening,n11,flow", r"flow.csv: missing column\(s\) \['q11'\]"),
        ("flow.csv", "opening,n11,q11", "opening,n11,q11,note", r"flow.csv: unknown column\(s\) \['note'\]"),
    ],
)
def test_garbage_header_or_key_is_rejected(chart_dir, file, old, new, message):
    _replace(chart_dir / file, old, new)
    with pytest.raises(InputError, match=message):
        load_chart(chart_dir)


def _set_cell(path, column, value, line=2):
    """Set one cell of a CSV (line numbers as in the error messages: header = line 1)."""
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[line - 1].split(",")
    cells[header.index(column)] = value
    lines[line - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "file,column,value,message",
    [
        ("flow.csv", "opening", "12.00x", r"flow.csv: row 2, column 'opening': not a number: '12.00x'"),
        ("flow.csv", "opening", "nan", r"flow.csv: row 2, column 'opening': value must be finite, got 'nan'"),
        ("flow.csv", "q11", "inf", r"flow.csv: row 2, column 'q11': value must be finite, got 'inf'"),
        ("flow.csv", "opening", "33.0",
         r"flow.csv: row 2, column 'opening': 33.0 is out of range; allowed 0 <= opening <= 32"),
        ("flow.csv", "opening", "-1.0", r"flow.csv: row 2, column 'opening': -1.0 is out of range"),
        ("flow.csv", "n11", "-50", r"flow.csv: row 2, column 'n11': -50.0 is out of range; allowed n11 >= 0"),
        ("efficiency.csv", "efficiency", "1.2",
         r"efficiency.csv: row 2, column 'efficiency': 1.2 is out of range; allowed \(0, 1\]"),
        ("efficiency.csv", "efficiency", "0.0", r"efficiency.csv: row 2, column 'efficiency': 0.0 is out of range"),
        ("efficiency.csv", "q11", "", r"efficiency.csv: row 2, column 'q11': not a number: ''"),
        ("runaway.csv", "n11", "-106.2", r"runaway.csv: row 2, column 'n11': -106.2 is out of range; allowed n11 >= 0"),
        ("runaway.csv", "q11", "-0.17", r"runaway.csv: row 2, column 'q11': -0.17 is out of range; allowed q11 >= 0"),
        # a runaway point without flow at an open runner (accepted before); 0.17 m^3/s passes
        ("runaway.csv", "q11", "0", r"runaway.csv: row 2, column 'q11': 0.0 is out of range; allowed q11 > 0 where "
                                    r"the opening is above 0"),
        ("runaway.csv", "opening", "32.5", r"runaway.csv: row 2, column 'opening': 32.5 is out of range"),
    ],
)
def test_garbage_value_is_rejected(chart_dir, file, column, value, message):
    _set_cell(chart_dir / file, column, value)
    with pytest.raises(InputError, match=message):
        load_chart(chart_dir)


def test_short_row_is_rejected(chart_dir):
    path = chart_dir / "runaway.csv"
    lines = path.read_text().splitlines()
    lines[1] = ",".join(lines[1].split(",")[:2])
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"runaway.csv: row 2 has 2 fields, the header has 3"):
        load_chart(chart_dir)


def test_duplicate_point(chart_dir):
    path = chart_dir / "efficiency.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines + [lines[5]]) + "\n")
    with pytest.raises(InputError, match=r"efficiency.csv: duplicate point .* at rows \[6, \d+\]"):
        load_chart(chart_dir)


def test_opening_line_with_two_points(chart_dir):
    path = chart_dir / "flow.csv"
    lines = path.read_text().splitlines()
    kept = [lines[0]] + [line for line in lines[1:] if not line.startswith("12.00,")] + [
        line for line in lines[1:] if line.startswith("12.00,")
    ][:2]
    path.write_text("\n".join(kept) + "\n")
    with pytest.raises(InputError, match=r"opening \[12.0\] have fewer than 3 points"):
        load_chart(chart_dir)


@pytest.mark.parametrize("name", ["chart.toml", "flow.csv", "efficiency.csv"])
def test_missing_file(chart_dir, name):
    (chart_dir / name).unlink()
    with pytest.raises(InputError, match=f"{name}: missing file"):
        load_chart(chart_dir)


def test_empty_and_header_only_files(chart_dir):
    (chart_dir / "flow.csv").write_text("")
    with pytest.raises(InputError, match="flow.csv: empty file"):
        load_chart(chart_dir)
    (chart_dir / "flow.csv").write_text("opening,n11,q11\n")
    with pytest.raises(InputError, match="flow.csv: no data rows"):
        load_chart(chart_dir)


def test_not_a_folder(tmp_path):
    with pytest.raises(InputError, match="not a chart folder"):
        load_chart(tmp_path / "nowhere")


def test_binary_file(chart_dir):
    (chart_dir / "flow.csv").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(InputError, match="flow.csv: not a UTF-8 text file"):
        load_chart(chart_dir)
