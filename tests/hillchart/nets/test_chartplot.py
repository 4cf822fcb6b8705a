"""Hill-chart figures and the plausibility checks behind them (synthetic chart and the real Sayano-Shushenskaya
chart)."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from hillchart.nets import chartplot
from hillchart.characteristics import IdealTurbine
from hillchart.extension.extend import ExtensionOptions, extend_samples
from hillchart.nets.hill_nets import load_nets
from hillchart.nets.training import train_nets
from hillchart.io.samples import load_chart
from hillsim.cli import main
from tests.external_charts import write_sayano_chart

CHART = Path(__file__).resolve().parents[3] / "data_synthetic" / "francis"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_efficiency_of_the_ideal_turbine_is_its_constant():
    t = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.87)
    n11, a = np.meshgrid(np.linspace(20, 120, 7), np.linspace(1, 30, 5))
    # eq. (5) inverted on eq. (5) itself: exact to rounding
    np.testing.assert_allclose(chartplot.efficiency_from_characteristics(t, n11, a), 0.87, rtol=1e-13)
    assert np.isnan(chartplot.efficiency_from_characteristics(t, 50.0, 0.0))  # Q11 = 0: 0/0 is NaN, not 0


def test_efficiency_at_points_inverts_the_flow():
    t = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)
    eta = chartplot.efficiency_at_points(t, [60.0, 60.0], [0.45, 0.7], opening_range=(0.0, 30.0))
    assert eta[0] == pytest.approx(0.9, rel=1e-12)
    assert np.isnan(eta[1])  # 0.7 m^3/s needs more than full opening


@pytest.fixture(scope="module")
def synthetic():
    return load_nets(CHART / "nets.json"), load_chart(CHART)


def test_synthetic_hill_chart_has_closed_islands_around_the_best_point(synthetic):
    nets, chart = synthetic
    # levels from 0.89 up close around the best point; 0.86 and below run into the chart's low-flow border, as on
    # a manufacturer's chart. 0.88 is left out: the exact turbine's 0.88 contour passes within 0.002 m^3/s of the
    # plotted region's top (Q11 0.598 against 0.600), less than the nets' Q11 accuracy there (0.3 %), so whether the
    # nets close it is chance
    islands = chartplot.efficiency_islands(nets, [0.89, 0.90, 0.92, 0.93], samples=chart)
    for level, lines in islands.items():
        # one closed loop per level: a single hill, no spurious second peak
        assert [closed for closed, _ in lines] == [True], level
    # the islands are nested: each higher level lies inside the lower one's N11 span
    spans = [(p[:, 0].min(), p[:, 0].max()) for (_, p), in islands.values()]
    assert all(lo1 < lo2 and hi2 < hi1 for (lo1, hi1), (lo2, hi2) in zip(spans, spans[1:]))


def test_synthetic_efficiency_at_digitized_points(synthetic):
    nets, chart = synthetic
    err = chartplot.efficiency_at_points(nets, chart.eff_n11, chart.eff_q11) - chart.eff_efficiency
    ok = np.isfinite(err)
    assert ok.mean() > 0.95  # only points beyond full opening drop out
    # digitization noise of the efficiency points plus two net errors: measured RMS 0.22 points, max 0.76
    assert np.sqrt(np.mean(err[ok] ** 2)) < 0.005 and np.max(np.abs(err[ok])) < 0.015


def test_chart_figure_has_all_panels(synthetic):
    nets, chart = synthetic
    fig = chartplot.chart_figure(nets, samples=chart, extended=extend_samples(chart))
    assert len(fig.axes) >= 5  # hill chart, 2 surfaces, 2 error plots (+ colorbars)
    titles = " ".join(ax.get_title() for ax in fig.axes)
    assert "Q11 net" in titles and "M11 net" in titles and "fit error" in titles
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_cli_chart_writes_png(tmp_path, capsys):
    out = tmp_path / "chart.png"
    assert main(["chart", str(CHART / "nets.json"), "--out", str(out), "--samples", str(CHART)]) == 0
    assert out.read_bytes()[:8] == PNG_MAGIC and out.stat().st_size > 50_000  # a full figure, not an empty canvas
    assert "wrote" in capsys.readouterr().out


def test_cli_chart_rejects_bad_nets_file(tmp_path, capsys):
    bad = tmp_path / "nets.json"
    bad.write_text('{"format": "other"}')
    assert main(["chart", str(bad), "--out", str(tmp_path / "c.png")]) == 2
    assert "key 'version' is missing" in capsys.readouterr().err


def test_cli_train_rejects_bad_hidden(tmp_path, capsys):
    assert main(["train", str(CHART), "--out", str(tmp_path / "n.json"), "--hidden", "0"]) == 2
    assert "--hidden must be an integer in [1, 30], got '0'" in capsys.readouterr().err


def test_cli_chart_rejects_mismatched_opening_unit(tmp_path, capsys, synthetic):
    nets, _ = synthetic
    doc = nets.to_dict()
    doc["units"]["opening"] = "deg"
    path = tmp_path / "nets.json"
    from hillchart.nets.hill_nets import HillNets

    HillNets.from_dict(doc).save(path)
    assert main(["chart", str(path), "--out", str(tmp_path / "c.png"), "--samples", str(CHART)]) == 2
    assert "opening_unit is 'mm' but the nets were trained with 'deg'" in capsys.readouterr().err


# ------------------------------------------------------------------------------------ real chart (external data)
@pytest.fixture(scope="module")
def sayano(tmp_path_factory):
    folder = write_sayano_chart(tmp_path_factory.mktemp("sayano"))  # skips when ../shared/external is absent
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no runaway.csv: the loader warns, as it should
        return load_chart(folder)


@pytest.mark.slow
@pytest.mark.external
def test_sayano_trains_with_default_extension(sayano):
    nets = train_nets(extend_samples(sayano), seed=0)
    n11, a = np.meshgrid(np.linspace(0, 100, 21), np.linspace(0, 58, 21))
    assert np.all(np.isfinite(nets.q11(n11, a))) and np.all(np.isfinite(nets.m11(n11, a)))
    # closed guide vanes: the zero-opening samples hold Q11 near 0. Measured max 0.019 m^3/s = 3 %
    # of the flow range: the default zero-speed samples of this chart are poor (see the next test) and the net
    # compromises between them; 5 % would flag a net that ignores the boundary
    assert np.max(np.abs(nets.q11(np.linspace(0, 100, 11), 0.0))) < 0.05 * 0.625


@pytest.mark.slow
@pytest.mark.external
@pytest.mark.parametrize("seed", [0, 2])
def test_sayano_hill_chart_is_plausible(sayano, seed, tmp_path):
    """The real chart's lines start at N11 = 56 r/min, so extrapolating them to N11 = 0 (zero-speed boundary) is
    unreliable (it gives M11(0, a) that rises and falls with a); the nets are trained without it."""
    nets = train_nets(extend_samples(sayano, ExtensionOptions(zero_speed=False)), seed=seed)
    # digitized best-efficiency contour 0.922 around N11 = 66.5 r/min, Q11 = 0.42 m^3/s
    best = np.array([66.5, 0.421])
    for level in (0.88, 0.90):
        loops = [p for closed, p in chartplot.efficiency_islands(nets, [level], samples=sayano)[level] if closed]
        from matplotlib.path import Path as MplPath

        assert any(MplPath(p).contains_point(best) for p in loops), level  # a closed island around the best point
    err = chartplot.efficiency_at_points(nets, sayano.eff_n11, sayano.eff_q11) - sayano.eff_efficiency
    high = (sayano.eff_efficiency >= 0.8) & np.isfinite(err)
    # real, hand-digitized contours: the nets reproduce the >= 0.80 contours to 1.3-2.2 points RMS (seeds 0-5);
    # 3 points is about the spacing of neighbouring contours on the printed chart
    assert np.sqrt(np.mean(err[high] ** 2)) < 0.03
    fig = chartplot.chart_figure(nets, samples=sayano, path=tmp_path / "sayano.png")
    import matplotlib.pyplot as plt

    plt.close(fig)
    assert (tmp_path / "sayano.png").stat().st_size > 50_000
