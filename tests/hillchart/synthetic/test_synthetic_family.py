"""The synthetic Francis family: three geometries spanning specific speed, digitization options,
byte-identical reproducibility, ``hillsim synth --turbine``."""

import filecmp
import warnings

import numpy as np
import pytest
from scipy.optimize import minimize

from data_synthetic import FRANCIS_DIR
from tests.chart_files import assert_chart_matches
from hillchart.errors import InputError
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import FAMILY, DigitizationOptions, write_synthetic_chart
from hillsim.cli import main


def _best_point(turbine):
    res = minimize(lambda x: -float(turbine.efficiency(x[0], x[1])), [65.0, 0.6 * turbine.opening_max],
                   method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-12})
    return -res.fun, res.x[0], res.x[1]


@pytest.mark.parametrize("name", list(FAMILY))
def test_each_turbine_is_in_the_issue_window(name):
    member = FAMILY[name]
    turbine = member.turbine()
    eta, n11_best, _ = _best_point(turbine)
    assert 0.90 <= eta <= 0.95  # the family's window: BEP efficiency 0.90-0.95
    ratios = [turbine.runaway_n11(a) / n11_best for a in member.layout.runaway_openings_mm]
    assert 1.5 <= min(ratios) and max(ratios) <= 2.6  # runaway/BEP N11 ratio 1.5-2.6 on the whole runaway curve
    # at least 8 contour levels exist on the chart (a level above the true best is simply not drawn)
    assert sum(level < eta for level in member.layout.efficiencies) >= 8


def test_family_spans_specific_speed():
    ns = {}
    for name, member in FAMILY.items():
        turbine = member.turbine()
        eta, n11, a = _best_point(turbine)
        ns[name] = n11 * np.sqrt(float(turbine.q11(n11, a)) * eta)  # n_s ~ N11 sqrt(P11) at the best point
    # measured: slow 28, medium 43, fast 64; each step at least 30 % apart
    assert ns["slow"] * 1.3 < ns["medium"] and ns["medium"] * 1.3 < ns["fast"]


def test_medium_with_default_options_is_the_shipped_chart(tmp_path):
    write_synthetic_chart(tmp_path, seed=0, turbine="medium", options=DigitizationOptions())
    assert_chart_matches(tmp_path, FRANCIS_DIR)  # to the last written digit (tests/chart_files.py)


OPTIONS = DigitizationOptions(points_per_line=6, spacing="uneven", noise_pct=0.3, opening_unit="%", q11_unit="l/s",
                              efficiency_unit="percent", runaway=True, opening_lines=8)


@pytest.mark.parametrize("name", list(FAMILY))
def test_options_are_reproducible_byte_for_byte(tmp_path, name):
    write_synthetic_chart(tmp_path / "a", seed=3, turbine=name, options=OPTIONS)
    write_synthetic_chart(tmp_path / "b", seed=3, turbine=name, options=OPTIONS)
    write_synthetic_chart(tmp_path / "c", seed=4, turbine=name, options=OPTIONS)
    for file in ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv", "truth.csv"):
        assert filecmp.cmp(tmp_path / "a" / file, tmp_path / "b" / file, shallow=False), file
    assert (tmp_path / "a" / "flow.csv").read_text() != (tmp_path / "c" / "flow.csv").read_text()


def test_options_shape_the_digitized_chart(tmp_path):
    write_synthetic_chart(tmp_path / "opt", seed=0, turbine="fast", options=OPTIONS)
    chart = load_chart(tmp_path / "opt")
    assert chart.info.opening_unit == "%" and chart.info.opening_max == 100.0
    assert chart.openings.size == 8
    for a in chart.openings:
        n = np.sort(chart.flow_n11[chart.flow_opening == a])
        assert n.size == 6
        gaps = np.diff(n)
        assert gaps.max() > 1.5 * gaps.min()  # uneven: Dirichlet(2) gaps; even spacing gives a ratio ~1 +- noise
    # units are converted back by the loader: efficiency fraction, Q11 m^3/s in the family's range
    assert 0.77 <= chart.eff_efficiency.min() and chart.eff_efficiency.max() <= 0.915
    assert 0.3 < chart.flow_q11.max() < 1.3


def test_units_change_only_the_numbers_written(tmp_path):
    """Same seed, mm/m3/s/fraction vs %/l/s/percent: after the loader's conversion the points agree to the rounding."""
    plain = DigitizationOptions(noise_pct=0.3)
    units = DigitizationOptions(noise_pct=0.3, opening_unit="%", q11_unit="l/s", efficiency_unit="percent")
    write_synthetic_chart(tmp_path / "a", seed=2, turbine="slow", options=plain)
    write_synthetic_chart(tmp_path / "b", seed=2, turbine="slow", options=units)
    a, b = load_chart(tmp_path / "a"), load_chart(tmp_path / "b")
    np.testing.assert_allclose(b.flow_opening * 24.0 / 100.0, a.flow_opening, atol=0.005 * 24 / 100 + 1e-12)
    np.testing.assert_allclose(b.flow_q11, a.flow_q11, atol=0.5e-4 + 1e-12)  # 4 decimals in m3/s = 1 in l/s
    np.testing.assert_allclose(b.eff_efficiency, a.eff_efficiency, atol=1e-12)
    truth_a = np.loadtxt(tmp_path / "a" / "truth.csv", delimiter=",", skiprows=1)
    truth_b = np.loadtxt(tmp_path / "b" / "truth.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(truth_b[:, 1] * 24.0 / 100.0, truth_a[:, 1], rtol=1e-9)


def test_without_runaway_there_is_no_runaway_file(tmp_path):
    files = write_synthetic_chart(tmp_path, turbine="slow", options=DigitizationOptions(runaway=False))
    assert "runaway.csv" not in files and not (tmp_path / "runaway.csv").exists()
    with pytest.warns(UserWarning, match="runaway"):
        assert not load_chart(tmp_path).has_runaway


def test_noise_level_scales_the_scatter(tmp_path):
    errors = {}
    for noise in (0.0, 0.3):
        folder = tmp_path / str(noise)
        write_synthetic_chart(folder, seed=1, turbine="medium", options=DigitizationOptions(noise_pct=noise))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chart = load_chart(folder)
        exact = FAMILY["medium"].turbine().q11(chart.flow_n11, chart.flow_opening)
        errors[noise] = np.std(chart.flow_q11 - exact)
    assert errors[0.0] < 1e-4  # rounding only (4 decimals) plus the N11 rounding's effect on Q11
    assert 0.002 < errors[0.3] < 0.006  # sigma 0.003 m3/s on Q11 (medium axes) plus the N11 noise through dQ11/dN11


@pytest.mark.parametrize("kwargs,field", [({"points_per_line": 2}, "points_per_line"),
                                          ({"points_per_line": 13}, "points_per_line"),
                                          ({"spacing": "random"}, "spacing"), ({"noise_pct": -1}, "noise_pct"),
                                          ({"noise_pct": float("nan")}, "noise_pct"),
                                          ({"opening_unit": "rad"}, "opening_unit"),
                                          ({"q11_unit": "m3/h"}, "q11_unit"),
                                          ({"efficiency_unit": "pu"}, "efficiency_unit"),
                                          ({"opening_lines": 2}, "opening_lines"), ({"runaway": "yes"}, "runaway")])
def test_bad_digitization_options(kwargs, field):
    with pytest.raises(InputError, match=field):
        DigitizationOptions(**kwargs)


def test_bad_turbine_and_seed(tmp_path):
    with pytest.raises(InputError, match="slow, medium, fast"):
        write_synthetic_chart(tmp_path, turbine="kaplan")
    with pytest.raises(InputError, match="seed"):
        write_synthetic_chart(tmp_path, seed=-1)
    assert not any(tmp_path.iterdir())  # nothing partial


def test_cli_synth_turbine_and_options(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "f"), "--turbine", "fast", "--points-per-line", "6", "--spacing", "uneven",
                 "--noise", "0.3", "--opening-unit", "%", "--q11-unit", "l/s", "--efficiency-unit", "percent",
                 "--opening-lines", "8", "--seed", "3"]) == 0
    write_synthetic_chart(tmp_path / "api", seed=3, turbine="fast", options=OPTIONS)
    for file in ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv", "truth.csv"):
        assert filecmp.cmp(tmp_path / "f" / file, tmp_path / "api" / file, shallow=False), file


@pytest.mark.parametrize("argv,message", [(["--turbine", "kaplan"], "--turbine must be one of"),
                                          (["--points-per-line", "2"], "--points-per-line must be"),
                                          (["--noise", "9"], "--noise must be"),
                                          (["--opening-unit", "rad"], "--opening-unit must be"),
                                          (["--seed", "-2"], "--seed must be")])
def test_cli_synth_bad_options_write_nothing(tmp_path, capsys, argv, message):
    assert main(["synth", str(tmp_path / "x")] + argv) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
