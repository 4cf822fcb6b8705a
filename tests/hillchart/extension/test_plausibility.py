"""Plausibility checks of a digitized chart: each mistake a digitizer makes gives an
InputError naming the file, the row and what looks wrong; the clean charts of the family pass."""

import shutil
import warnings

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.errors import InputError
from hillchart.extension.extend import extend_samples
from hillchart.extension.plausibility import check_chart
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import FAMILY, DigitizationOptions, write_synthetic_chart
from hillsim.cli import main


@pytest.fixture()
def chart_dir(tmp_path):
    folder = tmp_path / "chart"
    shutil.copytree(FRANCIS_DIR, folder)
    (folder / "nets.json").unlink()
    return folder


def _edit(folder, name, edit):
    lines = (folder / name).read_text().splitlines()
    lines = edit(lines)
    (folder / name).write_text("\n".join(lines) + "\n")


# the slow-speed turbine's charts in the fast tier, the other two turbines' in the slow tier (marker slow)
@pytest.mark.parametrize("name", [n if n == "slow" else pytest.param(n, marks=pytest.mark.slow) for n in FAMILY])
def test_clean_family_charts_pass(tmp_path, name):
    for i, options in enumerate((DigitizationOptions(), DigitizationOptions(
            points_per_line=12, spacing="uneven", noise_pct=0.3, q11_unit="l/s", efficiency_unit="percent"))):
        write_synthetic_chart(tmp_path / str(i), seed=1, turbine=name, options=options)
        assert check_chart(load_chart(tmp_path / str(i))) is None
    # the benchmark's digitization (8 lines of 6 uneven points, 0.3 % noise), several seeds: no false alarm
    # (216 such charts, 3-12 points per line, seeds 0-5, were checked once: none flagged)
    for seed in range(3):
        folder = tmp_path / f"u{seed}"
        write_synthetic_chart(folder, seed=seed, turbine=name, options=DigitizationOptions(
            points_per_line=6, spacing="uneven", noise_pct=0.3, opening_lines=8, runaway=False))
        with pytest.warns(UserWarning, match="runaway"):
            chart = load_chart(folder)
        assert check_chart(chart) is None


def test_percent_efficiency_declared_fraction(chart_dir):
    _edit(chart_dir, "efficiency.csv",
          lambda ls: [ls[0]] + [f"{100 * float(r.split(',')[0]):.1f},{r.split(',', 1)[1]}" for r in ls[1:]])
    with pytest.raises(InputError, match=r"efficiency.csv: row 2, column 'efficiency'.*look like percent"):
        load_chart(chart_dir)


def test_fraction_efficiency_declared_percent(chart_dir):
    _edit(chart_dir, "chart.toml", lambda ls: [r.replace('"fraction"', '"percent"') for r in ls])
    with pytest.raises(InputError, match=r"efficiency.csv: efficiency values up to 0.93\d look like fractions"):
        check_chart(load_chart(chart_dir))


def test_litres_declared_cubic_metres(chart_dir):
    for name in ("flow.csv", "efficiency.csv", "runaway.csv"):
        _edit(chart_dir, name,
              lambda ls: [ls[0]] + [",".join(r.split(",")[:2] + [f"{1000 * float(r.split(',')[2]):.1f}"])
                                    for r in ls[1:]])
    with pytest.raises(InputError, match=r"flow.csv: Q11 up to 601.8 looks like l/s.*set q11_unit = \"l/s\""):
        check_chart(load_chart(chart_dir))


def test_cubic_metres_declared_litres(chart_dir):
    _edit(chart_dir, "chart.toml", lambda ls: [r.replace('"m3/s"', '"l/s"') for r in ls])
    with pytest.raises(InputError, match=r"looks like m\^3/s, but chart.toml declares q11_unit = 'l/s'"):
        check_chart(load_chart(chart_dir))


def test_openings_written_as_fractions_in_a_percent_chart_are_warned_about(chart_dir):
    """The shipped chart's openings written as fractions of the full opening (0.3125-1) in a chart declared in % up
    to 100: its largest line is 1 % of the full stroke, where the shipped chart's is 100 % (no warning). It trained
    without a word; a run near full load would read the nets 70 times above every line."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped chart: no warning
        check_chart(load_chart(chart_dir))
    for name in ("flow.csv", "runaway.csv"):
        _edit(chart_dir, name, lambda ls: [ls[0]] + [f"{float(r.split(',')[0]) / 32:.4f},{r.split(',', 1)[1]}"
                                                     for r in ls[1:]])
    _edit(chart_dir, "chart.toml", lambda ls: [r.replace('"mm"', '"%"').replace("32.0", "100.0") for r in ls])
    with pytest.warns(UserWarning, match=r"flow.csv: the largest opening line is a = 1 %, 1 % of chart.toml's "
                                         r"opening_max = 100 %.*write them in %"):
        check_chart(load_chart(chart_dir))


def test_crossing_opening_lines(chart_dir):
    # relabel the 30 mm line as 12 mm and the 12 mm line as 30 mm: they cross every line between
    def swap(ls):
        out = [ls[0]]
        for r in ls[1:]:
            a, rest = r.split(",", 1)
            a = {"30.00": "12.00", "12.00": "30.00"}.get(a, a)
            out.append(f"{a},{rest}")
        return out

    _edit(chart_dir, "flow.csv", swap)
    with pytest.raises(InputError, match=r"flow.csv: the opening lines a = \S+ and a = \S+ cross: at N11 .*row \d+"):
        check_chart(load_chart(chart_dir))


def _misclick(folder, row, opening, dq):
    """The point on file row ``row`` of ``flow.csv`` (on the line ``opening``, as written) moved by ``dq`` m^3/s."""
    def bump(ls):
        a, n, q = ls[row - 1].split(",")
        assert a == opening
        ls[row - 1] = f"{a},{n},{float(q) + dq:.4f}"
        return ls

    _edit(folder, "flow.csv", bump)


def test_outlier_on_a_line_names_its_row(chart_dir):
    # a misclick: the 4th point of the 20 mm line (file row 41) 0.03 m3/s (5 % of the Q11 range) too high
    _misclick(chart_dir, 41, "20.00", 0.03)
    with pytest.raises(InputError, match=r"flow.csv: row 41 \(opening 20, .*off the smooth curve"):
        check_chart(load_chart(chart_dir))


def test_a_chart_read_from_a_poor_copy_is_judged_against_its_own_scatter(tmp_path):
    """A chart read at 1 % of the axes' full scale (the slow turbine, 12 points a line) scatters by 3.2 % of its Q11
    range about the leave-one-out quadratics, and its honest points lie up to 8.9 % off them and its neighbouring
    lines cross by up to 3.2 %: against the careful chart's 4 and 2 % it was refused (row 24 first). Judged against
    its own scatter (4 robust standard deviations, 12.9 %; crossings widened alike, 6.4 %) it trains, with a warning
    that says so, and its nets read the exact turbine within the measured-region bounds (Q11 RMS <= 0.5 %, M11 RMS
    <= 1 % of the range; measured 0.41 and 0.30 %). A misclick 0.06 m^3/s off (30 % of the range) is still
    refused, by its row."""
    from hillchart.io.samples import measured_region_mask
    from hillchart.nets.training import train_nets

    folder = tmp_path / "poor"
    write_synthetic_chart(folder, seed=0, turbine="slow", options=DigitizationOptions(points_per_line=12,
                                                                                      noise_pct=1.0))
    chart = load_chart(folder)
    with pytest.warns(UserWarning, match=r"the chart's points scatter by 3.2 % of the Q11 range .*beyond 12.9 % off "
                                         r"a line and 6.43 % across the next .*row 111 \(opening 21, .*8.9 % of the "
                                         r"Q11 range.*digitize the chart from a larger or sharper copy"):
        extended = extend_samples(chart)  # the extension runs the checks first
    nets = train_nets(extended, seed=0, ensemble=10)
    truth = np.genfromtxt(folder / "truth.csv", delimiter=",", names=True)
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, truth["n11"], truth["opening"])
    n11, opening = truth["n11"][inside], truth["opening"][inside]
    for net, column, bound in ((nets.q11, "q11", 0.005), (nets.m11, "m11", 0.01)):
        exact = truth[column][inside]
        assert np.sqrt(np.mean((net(n11, opening) - exact) ** 2)) / np.ptp(exact) <= bound, column

    _misclick(folder, 112, "21.00", 0.06)  # 0.2938 -> 0.3538 m^3/s
    with pytest.raises(InputError, match=r"flow.csv: row 112 \(opening 21, N11 47.87, .*\(allowed 1\d.\d+ %\): an "
                                         "outlier"):
        check_chart(load_chart(folder))


def test_zigzag_line(chart_dir):
    def zigzag(ls):
        for i in range(37, 44):  # 20 mm line: alternate +-0.02 m3/s
            a, n, q = ls[i].split(",")
            ls[i] = f"{a},{n},{float(q) + (0.02 if i % 2 else -0.02):.4f}"
        return ls

    _edit(chart_dir, "flow.csv", zigzag)
    with pytest.raises(InputError, match=r"flow.csv: row \d+ \(opening 20,.*an outlier or a zigzag"):
        check_chart(load_chart(chart_dir))


def test_all_points_at_one_n11(chart_dir):
    _edit(chart_dir, "flow.csv", lambda ls: [ls[0]] + [f"{r.split(',')[0]},60.00,{r.split(',')[2]}" for r in ls[1:]])
    with pytest.raises(InputError, match=r"flow.csv: every point sits at N11 = 60.0"):
        check_chart(load_chart(chart_dir))
    with pytest.raises(InputError, match="every point sits at N11"):  # the extension runs the same checks first
        extend_samples(load_chart(chart_dir))


def test_train_one_n11_writes_nothing(chart_dir, tmp_path, capsys):
    _edit(chart_dir, "flow.csv", lambda ls: [ls[0]] + [f"{r.split(',')[0]},60.00,{r.split(',')[2]}" for r in ls[1:]])
    out = tmp_path / "n.json"
    assert main(["train", str(chart_dir), "--out", str(out), "--no-zero-speed", "--quiet"]) == 2
    assert "every point sits at N11" in capsys.readouterr().err
    assert not out.exists()


def test_contours_outside_the_lines(chart_dir):
    # contours digitized with N11 scaled by 1.6 (another chart's axis): the lines do not lie among them either
    _edit(chart_dir, "efficiency.csv",
          lambda ls: [ls[0]] + [f"{r.split(',')[0]},{1.6 * float(r.split(',')[1]):.2f},{r.split(',')[2]}"
                                for r in ls[1:]])
    with pytest.raises(InputError, match=r"efficiency.csv: \d+ of 176 contour points lie outside the N11-Q11 "
                                         r"region.*and \d+ of 84 line points outside the contours'"):
        check_chart(load_chart(chart_dir))


def _upper_lines(chart_dir, lowest):
    """The shipped chart with its opening lines from ``lowest`` mm up (and their runaway points), all contours."""
    for name in ("flow.csv", "runaway.csv"):
        _edit(chart_dir, name, lambda ls: [ls[0]] + [r for r in ls[1:] if float(r.split(",")[0]) >= lowest])


def test_a_chart_of_its_upper_lines_with_every_contour_is_checked_at_the_whole_charts_scale(chart_dir):
    """Lines digitized near full load only (24-32 mm, 5 lines) with the whole chart's contours: a misclick is a share
    of the chart's Q11 axis, which the contours span (0.299 m^3/s), not of the five lines' 0.072. Judged on the
    lines' range, the honest point of the 24 mm line that misses the quadratic through its neighbours by
    0.0032 m^3/s (1.1 % of the chart's range) read as 4.5 % and the chart was refused; the contours beyond the
    lines, which refused it too, are a warning now that the lines lie among them. A 0.03 m^3/s misclick on the
    28 mm line (10 % of the chart's range) is still refused, by its row."""
    _upper_lines(chart_dir, 24.0)
    with pytest.warns(UserWarning, match=r"contour points lie outside .*the lines lie among the contours.*Digitize"):
        assert check_chart(load_chart(chart_dir)) is None

    _misclick(chart_dir, 18, "28.00", 0.03)
    with pytest.raises(InputError, match=r"flow.csv: row 18 \(opening 28, .*off the smooth curve"):
        check_chart(load_chart(chart_dir))


def test_values_near_1e308_are_range_errors(chart_dir):
    _edit(chart_dir, "flow.csv", lambda ls: ls[:5] + ["20.00,1e308,0.5"] + ls[6:])
    with pytest.raises(InputError, match=r"flow.csv: row 6, column 'n11': 1e\+308 is out of range; "
                                         r"allowed n11 >= 0 and n11 <= 1000"):
        load_chart(chart_dir)


def test_single_level_efficiency_file(chart_dir):
    _edit(chart_dir, "efficiency.csv", lambda ls: ls[:12])  # 11 points, all on the 0.80 contour
    with pytest.raises(InputError, match=r"efficiency.csv: all 11 points are at efficiency 0.8"):
        extend_samples(load_chart(chart_dir))


def test_byte_order_mark_is_not_a_column(chart_dir):
    text = (chart_dir / "flow.csv").read_bytes()
    (chart_dir / "flow.csv").write_bytes(b"\xef\xbb\xbf" + text)
    assert load_chart(chart_dir).flow_n11.size == 84


def test_rows_are_file_line_numbers_with_blank_lines(chart_dir):
    _edit(chart_dir, "flow.csv", lambda ls: ls[:3] + ["", ""] + ls[3:5] + ["10.00,-5,0.3"] + ls[5:])
    with pytest.raises(InputError, match=r"row 8, column 'n11'"):  # header 1, data 2-3, blank 4-5, data 6-7, bad 8
        load_chart(chart_dir)


def test_a_clean_chart_whose_best_contour_lies_below_its_best_point_is_not_refused(chart_dir):
    """The best contour is no bound on the nets' best point, which lies inside the innermost contour: the shipped
    chart with its contours above 0.92 removed has its nets' best point at about 0.935 (above 0.92 + 0.01, refused by
    the rule of the best contour), and its contours' own surface, where they constrain it, agrees with the nets."""
    import numpy as np

    from hillchart.characteristics import efficiency_from_characteristics
    from hillchart.extension.plausibility import efficiency_plausibility
    from hillchart.nets.training import train_nets

    path = chart_dir / "efficiency.csv"
    lines = path.read_text(encoding="utf-8").splitlines()
    kept = [lines[0]] + [line for line in lines[1:] if float(line.split(",")[0]) <= 0.92]
    path.write_text("\n".join(kept) + "\n", encoding="utf-8")
    chart = load_chart(chart_dir)
    assert chart.eff_efficiency.max() == pytest.approx(0.92)
    nets = train_nets(extend_samples(chart), ensemble=0, seed=0, hidden=6)
    n11, a = np.meshgrid(np.linspace(55, 80, 26), np.linspace(14, 30, 17))
    assert np.nanmax(efficiency_from_characteristics(nets, n11, a)) > 0.93  # what the old rule refused
    assert efficiency_plausibility(nets, chart) is None


def test_nets_whose_efficiency_contradicts_the_contours_are_refused(chart_dir):
    """The failing case beside it: torque nets 4 % too strong (a unit or extension error) put the efficiency above
    the contours' surface by several points where the contours constrain it."""
    from dataclasses import replace

    from hillchart.extension.plausibility import efficiency_plausibility
    from hillchart.nets.hill_nets import HillNets, load_nets

    nets = load_nets(FRANCIS_DIR / "nets.json")
    chart = load_chart(chart_dir)
    assert efficiency_plausibility(nets, chart) is None
    t = nets.torque
    strong = HillNets(flow=nets.flow, torque=replace(t, y_min=1.04 * t.y_min, y_max=1.04 * t.y_max),
                      opening_unit=nets.opening_unit)
    message = efficiency_plausibility(strong, chart)
    assert message is not None and "above the chart's contours in the median" in message
