"""Torque from efficiency and the boundary families, against the synthetic turbine's exact truth."""

import shutil

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.errors import InputError, NumericalError
from hillchart.extension.extend import ExtensionOptions, extend_samples, fit_efficiency_surface, read_extended_csv
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import SyntheticFrancis
from tests.external_charts import write_sayano_chart

TURBINE = SyntheticFrancis()
CHART = load_chart(FRANCIS_DIR)
EXTENDED = extend_samples(CHART)


def _truth(target, x):
    f = TURBINE.q11 if target == "q11" else TURBINE.m11
    return f(x[:, 0], x[:, 1])


def test_measured_torque_within_2_percent_of_truth_range():
    x, m11, origin = EXTENDED.select("m11")
    measured = origin == "measured"
    truth = _truth("m11", x[measured])
    # the M11 range over the measured region of the chart (its openings and N11 span), from the exact model
    n, a = np.meshgrid(np.linspace(CHART.flow_n11.min(), CHART.flow_n11.max(), 60), CHART.openings)
    span = np.ptp(TURBINE.m11(n, a))
    # the accuracy bound: within 2 % of the truth M11 range; digitization noise (0.0015 m3/s on Q11, 0.15 r/min)
    # alone is about 0.5 %, so 2 % leaves room only for a sound efficiency surface
    assert np.abs(m11[measured] - truth).max() < 0.02 * span


def test_flow_samples_are_the_digitized_points():
    x, q11, origin = EXTENDED.select("q11")
    measured = origin == "measured"
    np.testing.assert_array_equal(q11[measured], CHART.flow_q11)
    np.testing.assert_array_equal(x[measured, 0], CHART.flow_n11)


def test_runaway_samples_have_zero_torque():
    x, m11, origin = EXTENDED.select("m11")
    assert np.all(m11[origin == "runaway"] == 0.0)
    assert np.sum(origin == "runaway") == CHART.runaway_n11.size
    # and the true torque there is small: runaway digitized with 0.15 r/min noise, dM11/dN11 ~ -10 N*m/(r/min)
    assert np.abs(_truth("m11", x[origin == "runaway"])).max() < 10.0


def test_zero_opening_boundary():
    xq, q11, oq = EXTENDED.select("q11")
    xm, m11, om = EXTENDED.select("m11")
    assert np.all(q11[oq == "zero-opening"] == 0.0) and np.all(xq[oq == "zero-opening", 1] == 0.0)
    k = EXTENDED.k_zero_opening
    assert k > 0  # a braking torque at zero opening
    n = xm[om == "zero-opening", 0]
    np.testing.assert_allclose(m11[om == "zero-opening"], -k * n**2, rtol=1e-15)
    assert n.min() == 0 and n.max() == pytest.approx(max(CHART.flow_n11.max(), CHART.runaway_n11.max()))
    # extrapolating from 10..32 mm to 0 is rough (paper section 2.6 (3)): K lands within a factor 5 of the truth
    assert TURBINE.params.k_disc_friction / 5 < k < 5 * TURBINE.params.k_disc_friction


def test_zero_speed_boundary_is_rough_but_physical():
    for target in ("q11", "m11"):
        x, y, origin = EXTENDED.select(target)
        zs = origin == "zero-speed"
        assert zs.sum() == CHART.openings.size and np.all(x[zs, 0] == 0)
        truth = _truth(target, x[zs])
        assert np.all(y[zs] > 0)  # standstill: positive flow and starting torque
        # the extrapolation error (measured by benchmarks/bench_extension.py) stays below 15 % of the truth span
        assert np.abs(y[zs] - truth).max() < 0.15 * np.ptp(truth)


@pytest.mark.parametrize("switch,origin",
                         [("runaway", "runaway"), ("zero_opening", "zero-opening"), ("zero_speed", "zero-speed")])
def test_each_boundary_can_be_switched_off(switch, origin):
    ext = extend_samples(CHART, ExtensionOptions(**{switch: False}))
    assert ext.counts()["q11"][origin] == 0 and ext.counts()["m11"][origin] == 0
    others = [o for o in ("runaway", "zero-opening", "zero-speed") if o != origin]
    assert all(ext.counts()["m11"][o] > 0 for o in others)


def test_user_k_overrides_the_fit():
    ext = extend_samples(CHART, ExtensionOptions(zero_opening_k=0.002))
    x, m11, origin = ext.select("m11")
    z = origin == "zero-opening"
    np.testing.assert_allclose(m11[z], -0.002 * x[z, 0] ** 2)
    assert ext.k_zero_opening_fitted == pytest.approx(EXTENDED.k_zero_opening)


def test_non_positive_k_is_reported(tmp_path):
    # a chart whose torque grows towards small openings extrapolates to positive torque at a = 0
    for name in ("chart.toml", "efficiency.csv"):
        shutil.copy(FRANCIS_DIR / name, tmp_path / name)
    rows = ["opening,n11,q11"]
    for a in (10.0, 20.0, 30.0):
        for n in (50.0, 60.0, 70.0, 80.0):
            rows.append(f"{a},{n},{0.6 - 0.01 * a:.4f}")
    (tmp_path / "flow.csv").write_text("\n".join(rows) + "\n")
    with pytest.warns(UserWarning):
        chart = load_chart(tmp_path)
    with pytest.raises(NumericalError, match=r"K = -?[0-9.e+-]+ N\*m/\(r/min\)\^2 .* set zero_opening_k"):
        extend_samples(chart, ExtensionOptions(zero_speed=False, boundaries="polynomial", check_chart=False))
    # the user's K makes it go through, as the paper's hand adjustment does
    ext = extend_samples(chart, ExtensionOptions(zero_speed=False, zero_opening_k=0.003, boundaries="polynomial",
                                                 check_chart=False))
    assert ext.k_zero_opening == 0.003
    # the default physical-model boundaries refuse this chart (no turbine has it), saying what to provide
    with pytest.raises(InputError, match=r"no physically valid boundary .*runaway.csv.*--zero-opening-k"):
        extend_samples(chart, ExtensionOptions(zero_speed=False, check_chart=False))
    # with its runaway curve the refusal does not ask for one
    (tmp_path / "runaway.csv").write_text("opening,n11,q11\n10,120,0.45\n20,125,0.35\n30,130,0.25\n")
    with pytest.raises(InputError, match="no physically valid boundary") as refused:
        extend_samples(load_chart(tmp_path), ExtensionOptions(zero_speed=False, check_chart=False))
    assert "runaway.csv" not in str(refused.value) and "--boundaries polynomial" in str(refused.value)
    (tmp_path / "runaway.csv").unlink()
    # and the plausibility check (on by default) names what is wrong with it first: its lines cross
    with pytest.raises(InputError, match="cross"):
        extend_samples(chart)


@pytest.mark.parametrize(
    "kwargs,field",
    [
        ({"extrapolation_degree": 0}, "extrapolation_degree"),
        ({"extrapolation_degree": 2.5}, "extrapolation_degree"),
        ({"zero_opening_points": 1}, "zero_opening_points"),
        ({"zero_opening_k": -1.0}, "zero_opening_k"),
        ({"zero_opening_k": float("nan")}, "zero_opening_k"),
        ({"efficiency_degree": 12}, "efficiency_degree"),
    ],
)
def test_bad_options(kwargs, field):
    with pytest.raises(InputError, match=field):
        ExtensionOptions(**kwargs)


def test_efficiency_surface_recovers_a_polynomial_exactly():
    rng = np.random.default_rng(3)
    n, q = rng.uniform(50, 90, 150), rng.uniform(0.3, 0.6, 150)
    eta = 0.9 - 2e-5 * (n - 70) ** 2 - 0.5 * (q - 0.45) ** 2 + 1e-3 * (n - 70) * (q - 0.45)
    surface = fit_efficiency_surface(n, q, eta)
    assert surface.degree == 2  # parsimony picks the true degree
    assert abs(float(surface(66.0, 0.41)) - (0.9 - 2e-5 * 16 - 0.5 * 0.0016 + 1e-3 * -4 * -0.04)) < 1e-12


def test_csv_round_trip(tmp_path):
    path = EXTENDED.to_csv(tmp_path / "ext.csv")
    assert path.read_text().splitlines()[0] == "target,origin,n11,opening,value"
    back = read_extended_csv(path, opening_unit="mm", opening_max=32.0)
    for name in ("target", "origin", "n11", "opening", "value"):
        np.testing.assert_array_equal(getattr(back, name), getattr(EXTENDED, name))  # repr floats: exact


def test_csv_saved_again_by_a_spreadsheet_reads_back(tmp_path):
    path = EXTENDED.to_csv(tmp_path / "ext.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0].replace(",", ";")] + [";".join(c.replace(".", ",") for c in line.split(","))
                                                                for line in lines[1:]]) + "\n")
    assert ";" in path.read_text() and "." not in path.read_text().split("\n", 1)[1]
    with pytest.warns(UserWarning, match="semicolon-separated with decimal commas"):
        back = read_extended_csv(path, opening_unit="mm", opening_max=32.0)
    for name in ("target", "origin", "n11", "opening", "value"):
        np.testing.assert_array_equal(getattr(back, name), getattr(EXTENDED, name))  # the same digits: exact


@pytest.mark.parametrize(
    "line,message",
    [
        ("q12,measured,1,2,3", r"row 2, column 'target': 'q12'"),
        ("q11,guessed,1,2,3", r"row 2, column 'origin': 'guessed'"),
        ("q11,measured,1,x,3", r"row 2, column 'opening': not a number"),
        ("q11,measured,1,2,nan", r"row 2, column 'value': value must be finite"),
        ("q11,measured,1,2", r"row 2 has 4 fields"),
    ],
)
def test_extended_csv_garbage(tmp_path, line, message):
    (tmp_path / "e.csv").write_text("target,origin,n11,opening,value\n" + line + "\n")
    with pytest.raises(InputError, match=message):
        read_extended_csv(tmp_path / "e.csv", opening_unit="mm", opening_max=32.0)


@pytest.mark.external
def test_sayano_shushenskaya_chart_extends(tmp_path):
    folder = write_sayano_chart(tmp_path / "sayano")
    with pytest.warns(UserWarning, match="runaway"):
        chart = load_chart(folder)
    assert chart.flow_q11.max() < 1.0  # l/s were converted to m3/s
    ext = extend_samples(chart)
    xq, q11, oq = ext.select("q11")
    xm, m11, om = ext.select("m11")
    z = xq[:, 1] == 0
    assert z.sum() >= 2 and np.all(q11[z] == 0.0)
    zm = (xm[:, 1] == 0) & (xm[:, 0] > 0)
    assert zm.sum() >= 2 and np.all(m11[zm] < 0)
    # no runaway.csv: the default takes the runaway samples from the fitted model (derived, soft constraints); the
    # paper's polynomial extension has none
    run = ext.origin == "runaway"
    assert run.sum() >= 2 and np.all(ext.derived[run])
    assert extend_samples(chart, ExtensionOptions(boundaries="polynomial")).counts()["m11"]["runaway"] == 0
    # the model fitted to this chart ends (its pumping limit, N11 = 104.9) before the runaway speed of its 8 largest
    # openings: no runaway sample there, and the extension says so and what to give (measured: 8 of the 12 lines)
    assert run.sum() == 2 * 4
    assert len(ext.warnings) == 1 and "8 of the 12 opening lines (a = 26, 30, 34, 38, 42, 46, 54, 58 mm)" in (
        ext.warnings[0]) and "runaway.csv" in ext.warnings[0]


@pytest.mark.external
def test_lines_without_a_model_runaway_are_continued_straight(tmp_path):
    """Sayano's 8 lines the model gives no runaway speed beyond are continued straight through their two last points
    (:func:`continued_line_points`), at half and all of the gap cap of the held-out line ends; the members' torque
    there moves in the band of the continuations' own misses, not the model's (by hand, 1e-12: the same formula)."""
    from hillchart.extension.band import continuation
    from hillchart.extension.silent_samples import CONTINUED_FRACTIONS

    with pytest.warns(UserWarning):
        chart = load_chart(write_sayano_chart(tmp_path / "sayano"))
        ext = extend_samples(chart)
    x = ext.extrapolation
    over = x.overspeed
    assert x.bare == ext.lines_without_runaway and len(x.bare) == 8
    torque = {(n, o): m for (n, o), m in zip(zip(*ext.select("m11")[0].T), ext.select("m11")[1])}
    for a in x.bare:
        on = chart.flow_opening == a
        last = chart.flow_n11[on].max()
        xq, q, origin = ext.select("q11")
        beyond = (xq[:, 1] == a) & (xq[:, 0] > last * (1 + 1e-9)) & (origin == "silent-region")
        want = last * (1.0 + np.array(CONTINUED_FRACTIONS) * over["gap_cap"])
        np.testing.assert_allclose(np.sort(xq[beyond, 0]), want, rtol=1e-12)
        measured = np.array([torque[(n, a)] for n in chart.flow_n11[on]])
        for n in want:
            assert torque[(n, a)] == pytest.approx(continuation(chart.flow_n11[on], measured, n), rel=1e-12)
        low, high = x.overspeed_widths(want, np.full(2, a))
        band = over["line_m11_band_per_gap"]
        gaps = np.minimum(want / last - 1.0, over["gap_cap"])
        np.testing.assert_allclose(high, band["high"] * over["m11_scale"] * gaps, rtol=1e-12)
        assert band != over["m11_band_per_gap"]


def test_a_model_without_runaway_beyond_a_line_s_end_is_warned_of():
    """:func:`runaway_warning` names the lines the fitted model gives no runaway speed beyond; none when it gives one
    beyond every line, or the chart has its runaway curve (the shipped chart: the model's runaway lies beyond every
    line's end)."""
    from dataclasses import replace

    from hillchart.extension.silent_samples import runaway_warning

    without = replace(CHART, runaway_opening=CHART.runaway_opening[:0], runaway_n11=CHART.runaway_n11[:0],
                      runaway_q11=CHART.runaway_q11[:0])
    model = EXTENDED.boundary_model
    assert runaway_warning(CHART, model) is None and runaway_warning(without, model) is None

    class Ending:  # the model, its valid range ending at the chart's largest N11: no runaway above 20 mm
        n11_limit = float(CHART.flow_n11.max())

        def runaway_n11(self, opening):
            return model.runaway_n11(opening) if opening <= 20.0 else float("nan")

    lines = [a for a in np.unique(CHART.flow_opening) if a > 20.0]
    note = runaway_warning(without, Ending())
    assert f"{len(lines)} of the {np.unique(CHART.flow_opening).size} opening lines" in note
    assert f"a = {', '.join(f'{a:g}' for a in lines)} mm" in note and "runaway.csv" in note
