"""The guarantee figures on transient.png: each maximum (and the min head) marked with its value, its ensemble band
(an error bar) and its extrapolation share, read from the figure's artists and text."""

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from simulate.config import load_plant
from simulate.loop.engine import run_simulation
from simulate.results.result import extrapolation_share
from simulate.studies.uncertainty import run_ensemble


@pytest.fixture(scope="module")
def banded_run():
    plant = load_plant(PLANT_HLA339, {"scenario.t_end_s": 12.0})  # both maxima and the first head minimum
    band, traces = run_ensemble(plant)
    return run_simulation(plant), band, traces


def _texts(ax, figure):
    return [t.get_text() for t in ax.texts if t.get_gid() == f"guarantee:{figure}"]


def _bars(ax, figure):
    return [c for c in ax.collections if c.get_gid() == f"guarantee-band:{figure}"]


def test_each_figure_is_marked_with_its_band_and_extrapolation_share(banded_run, tmp_path):
    result, band, traces = banded_run
    summary = result.summary()
    fig = result.plot(tmp_path / "transient.png", band=traces)
    speed_ax, head_ax = fig.axes[0], fig.axes[1]
    n0, h0 = result.speed_rpm[0], result.head_m[0]
    for ax, figure, v0, sign, unit in ((speed_ax, "max_speed_rise", n0, 1, "r/min"),
                                       (head_ax, "max_head_rise", h0, 1, "m"),
                                       (head_ax, "min_head_drop", h0, -1, "m")):
        (text,) = _texts(ax, figure)
        value = v0 * (1 + sign * summary[figure])
        assert f"{value:.1f} {unit} ({'+' if sign > 0 else '-'}{100 * summary[figure]:.2f} %)" in text
        low, high = sorted(v0 * (1 + sign * band[figure][k]) for k in ("low", "high"))
        assert f"band {low:.1f}-{high:.1f} {unit}" in text
        share = summary["extrapolation"]["figures"][figure]["digitized_region"]
        assert f"{100 * share:.0f} % of the run up to it outside the digitized chart" in text
        # the error bar spans the band at the figure's time (the summary's time of the maximum / minimum)
        (bar,) = _bars(ax, figure)
        (segment,) = bar.get_segments()
        assert segment[:, 0] == pytest.approx([summary["extrapolation"]["figures"][figure]["time_s"]] * 2)
        assert sorted(segment[:, 1]) == pytest.approx([low, high], rel=1e-12)
        assert low <= value <= high or abs(value - np.clip(value, low, high)) < 0.02 * v0  # the point run near it
    # the load rejection of the shipped unit leaves the chart before its maxima: a share that is not 0
    assert 0.2 < summary["extrapolation"]["figures"]["max_head_rise"]["digitized_region"] < 0.8


def test_without_a_band_the_marks_carry_value_and_share_only(banded_run, tmp_path):
    result, _, _ = banded_run
    fig = result.plot(tmp_path / "plain.png")
    (text,) = _texts(fig.axes[0], "max_speed_rise")
    assert "band" not in text and "outside the digitized chart" in text
    assert _bars(fig.axes[0], "max_speed_rise") == []


def test_extrapolation_share_prefers_the_digitized_region():
    record = {"figures": {"max_speed_rise": {"time_s": 9.8, "training_range": 0.1, "digitized_region": 0.4}}}
    assert extrapolation_share(record, "max_speed_rise") == ("digitized_region", 0.4)
    assert extrapolation_share({"figures": {"max_speed_rise": {"training_range": 0.1}}}, "max_speed_rise") == (
        "training_range", 0.1)
    assert extrapolation_share(record, "min_head_drop") is None and extrapolation_share(None, "x") is None
