"""``hillsim run --uncertainty``: the scenario once per ensemble member of the nets."""

import json
import tomllib

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR, PLANT_HLA339
from hillchart.errors import InputError
from hillchart.nets.hill_nets import HillNets, load_nets
from hillsim.cli import main
from simulate.config import load_plant, plant_from_dict
from simulate.loop.engine import run_simulation
from simulate.studies import uncertainty

SHORT = {"scenario.t_end_s": 8.0}  # the speed and head peaks of the load rejection come within 8 s


def test_band_over_the_members_costs_one_run_each(monkeypatch):
    import simulate.loop.engine as engine

    calls = []
    real = engine.run_simulation

    def counting(plant, characteristics=None, **kwargs):
        calls.append(characteristics)
        return real(plant, characteristics, **kwargs)

    monkeypatch.setattr(engine, "run_simulation", counting)
    plant = load_plant(PLANT_HLA339, SHORT)
    band = uncertainty.run_members(plant)
    assert band["members"] == 10 and band["failed"] == [] and len(calls) == 10  # N members: N runs
    for name in uncertainty.BAND_FIGURES:
        values = band[name]["values"]
        assert len(values) == 10
        # the members' 5-95 % spread widened about their median (BAND_INFLATION >= 1): it contains the plain
        # percentiles and the mean
        low, high = np.percentile(values, [5.0, 95.0])
        assert band[name]["low"] <= low <= band[name]["mean"] <= high <= band[name]["high"]
        assert (band[name]["low"], band[name]["high"]) == pytest.approx(uncertainty.figure_band(values), abs=1e-15)
    # load rejection of the HLA339-like unit: about 45 % speed rise for every member (the nets agree near rated)
    assert 0.40 < band["max_speed_rise"]["low"] <= band["max_speed_rise"]["high"] < 0.50


def test_nets_without_ensemble_or_ideal_are_refused():
    plant = load_plant(PLANT_HLA339, SHORT)
    shipped = load_nets(FRANCIS_DIR / "nets.json")
    single = HillNets(flow=shipped.flow, torque=shipped.torque, opening_unit="mm")
    with pytest.raises(InputError, match="has none"):
        uncertainty.run_members(plant, single)
    with pytest.raises(InputError, match="ideal"):
        uncertainty.run_members(load_plant(PLANT_HLA339, dict(SHORT, **{"turbine.characteristics": "ideal"})))
    with pytest.raises(InputError, match="percentiles"):
        uncertainty.run_members(plant, shipped, percentiles=(50, 10))


def test_cli_writes_the_band_into_summary_json(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(PLANT_HLA339), "--out", str(out), "--set", "scenario.t_end_s=8.0", "--no-plot",
                 "--uncertainty"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    band = summary["uncertainty"]
    assert band["members"] == 10
    assert band["max_speed_rise"]["low"] <= summary["max_speed_rise"] + 0.02  # the point run sits near the band
    assert "ensemble of 10 (0 failed): max speed rise" in capsys.readouterr().out


def test_trace_band_is_drawn_on_the_transient_figure(tmp_path):
    """``run --uncertainty`` draws the members' 5-95 % band behind the point run."""
    plant = load_plant(PLANT_HLA339, SHORT)
    band, traces = uncertainty.run_ensemble(plant)
    assert traces.members == band["members"] == 10
    for name in uncertainty.BAND_TRACES:
        assert traces.low[name].shape == traces.time_s.shape
        assert np.all(traces.low[name] <= traces.high[name])
    # the band is not degenerate: the members differ (measured: up to ~2 % of the rated head after closure)
    assert np.max(traces.high["head_m"] - traces.low["head_m"]) > 0.5
    # its peak speed band is the summary band of max speed rise (same runs, same percentiles)
    speed0 = traces.low["speed_rpm"][0]
    assert np.max(traces.high["speed_rpm"]) / speed0 - 1 == pytest.approx(band["max_speed_rise"]["high"], abs=0.01)
    from simulate.loop.engine import run_simulation

    result = run_simulation(plant)
    fig = result.plot(tmp_path / "t.png", band=traces)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "ensemble of 10, 5-95 %" in labels and "point nets" in labels
    banded = [ax for ax in fig.axes if any(type(c).__name__ in ("PolyCollection", "FillBetweenPolyCollection")
                                          for c in ax.collections)]
    assert len(banded) == 4  # speed, head, flow, opening
    plain = result.plot(tmp_path / "plain.png")
    assert plain.axes[0].get_legend() is None or "point nets" not in [
        t.get_text() for t in plain.axes[0].get_legend().get_texts()]


def test_cli_draws_the_band(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(PLANT_HLA339), "--out", str(out), "--set", "scenario.t_end_s=8.0", "--uncertainty"]) == 0
    assert (out / "transient.png").stat().st_size > 20_000
    assert "uncertainty" in json.loads((out / "summary.json").read_text())


def test_the_band_of_the_draft_tube_s_lowest_pressure_decides_its_limit():
    """A draft tube under the HLA339-like unit (runner outlet 2 m below the tailwater, 20 m down to 6 m below it):
    every member gives ``min_draft_tube_pressure_head_m``, so it is banded, and the limit is judged on the band's
    low end, never milder than the point nets' figure."""
    from simulate.studies.case_results import case_from_result
    from simulate.studies.cases import Limits

    raw = tomllib.loads(PLANT_HLA339.read_text(encoding="utf-8"))
    raw["scenario"]["t_end_s"] = 8.0
    raw["draft_tube"] = {"model": "moc", "runner_elevation_m": -2.0, "segments": [
        {"length_m": 20.0, "diameter_m": 4.0, "wave_speed_m_s": 1000.0, "darcy_friction": 0.014,
         "elevation_start_m": -2.0, "elevation_end_m": -6.0}]}
    plant = plant_from_dict(raw, base_dir=PLANT_HLA339.parent)
    band = uncertainty.run_members(plant)
    figure = band["min_draft_tube_pressure_head_m"]
    assert len(figure["values"]) == band["members"] == 10
    point = run_simulation(plant)
    value = point.summary()["min_draft_tube_pressure_head_m"]
    # measured: the point nets 8.66 m, the band 8.32-8.86 m (the members' speed rises differ, and with them the
    # water column's deceleration below the runner); the band's low end lies 0.1 m or more below the point figure
    assert figure["low"] < value - 0.1 < value < figure["high"]
    # a limit between the band's low end and the point figure fails on the band, passes on the point nets
    allowed = 0.5 * (figure["low"] + value)
    case = case_from_result(0, {}, plant, point)
    (on_band,) = Limits(min_draft_tube_pressure_head_m=allowed).check(case, band)
    (on_point,) = Limits(min_draft_tube_pressure_head_m=allowed).check(case)
    assert on_band["judged"] == "band" and on_band["verdict"] == "FAIL"
    assert on_point["judged"] == "point" and on_point["verdict"] == "PASS"
