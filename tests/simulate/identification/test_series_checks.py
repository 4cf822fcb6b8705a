"""Measured series in the wrong units, outliers, memory; identify's honest report."""

import math
from pathlib import Path

import numpy as np
import pytest

from hillchart.errors import InputError
from hillsim.commands.identify import has_quiet_tail, review_summary
from simulate.config import load_plant
from simulate.identification.experiment import ExperimentSettings
from simulate.identification.results import (ArxEstimate, ArxResults, ArxStructure, CoefficientSet,
                                             IdentificationSummary, ResidualRms, SimulationModeError,
                                             SixCoefficientResult, to_json_dict)
from simulate.identification.tables import markdown_tables
from simulate.identification.measured import MEASURED_COLUMNS, OperatingPoint, load_measured_series
from simulate.identification.series_checks import (check_against_plant, check_measured_table, check_time,
                                    hampel_outliers,
                                    small_signal_warning)

REPO = Path(__file__).resolve().parents[3]
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"


def _columns(n=300, dt=0.02):
    """A plausible measured series of the shipped plant: small opening steps around stroke 0.68."""
    t = dt * np.arange(n)
    y = 0.68 * (1 + 0.01 * (t > 1.0))
    return {"time_s": t, "speed_rpm": 200 * (1 + 0.002 * np.sin(t)), "head_m": 176 + 0 * t, "opening": y,
            "torque_nm": 1.07e7 * (1 + 0.01 * np.sin(t)), "flow_m3_s": 142.5 * y / 0.68}


def _write(path, cols):
    lines = [",".join(MEASURED_COLUMNS)] + [",".join(repr(float(cols[c][i])) for c in MEASURED_COLUMNS)
                                            for i in range(len(cols["time_s"]))]
    path.write_text("\n".join(lines) + "\n")
    return path


ROWS = np.arange(300) + 2  # file line numbers of a header + 300 rows


def test_a_plausible_series_passes():
    check_measured_table("s.csv", _columns(), ROWS, sample_time_s=0.2)  # nothing raised


@pytest.mark.parametrize("scale, unit", [(100.0, "%"), (32.0, "mm")])
def test_opening_in_percent_or_chart_units_is_refused(scale, unit):
    """An opening at 68x full stroke must be refused (it once gave eqy 4.8e-177 and exit 0)."""
    cols = _columns()
    cols["opening"] = cols["opening"] * scale
    with pytest.raises(InputError, match=r"s.csv: column 'opening' must be the stroke fraction in \[0, 1.5\].*"
                                         r"at rows 2, 3, 4, 5, 6 and 295 more \(the values look like %"):
        check_measured_table("s.csv", cols, ROWS, sample_time_s=0.2)


@pytest.mark.parametrize("factor, unit", [(1e3, "ms"), (1e6, "us")])
def test_time_in_ms_or_us_is_refused_with_the_likely_unit(factor, unit):
    """Time in us must be refused before resampling (it once was killed for memory at 24 GB)."""
    cols = _columns()
    cols["time_s"] = cols["time_s"] * factor
    with pytest.raises(InputError, match=rf"median sampling interval is {0.02 * factor:g} s.*is time in {unit}\? "
                                         rf"then the sampling interval is 0.02 s"):
        check_measured_table("s.csv", cols, ROWS, sample_time_s=0.2)


def test_memory_estimate_refuses_a_huge_resampling():
    t = 0.2 * np.arange(1000)  # 200 s at tau 0.2 s: 1000 samples, about 1 MB by the estimate
    check_time("s.csv", t, t * 0 + 2, sample_time_s=0.2, max_bytes=2e6)  # passes under 2 MB
    with pytest.raises(InputError, match=r"spans 199.8 s: at tau = 0.2 s that is 1e\+03 samples, about 0.000954 GiB"):
        check_time("s.csv", t, t * 0 + 2, sample_time_s=0.2, max_bytes=5e5)


def test_outliers_are_named_by_row(tmp_path):
    """Samples of 1e308 or -200 r/min are reported, never dropped in resampling without a word."""
    cols = _columns()
    cols["head_m"][100] = 1e308
    with pytest.raises(InputError, match=r"s.csv: column 'head_m': isolated outlier\(s\) at row 102 \(values 1e\+308"):
        load_measured_series(_write(tmp_path / "s.csv", cols), sample_time_s=0.2)
    cols = _columns()
    cols["speed_rpm"][200] = -200
    with pytest.raises(InputError, match=r"column 'speed_rpm' must be > 0 r/min: -200 at row 202"):
        load_measured_series(_write(tmp_path / "s.csv", cols), sample_time_s=0.2)
    cols = _columns()
    cols["torque_nm"][50:52] = 0.0  # a two-sample sensor dropout
    with pytest.raises(InputError, match=r"column 'torque_nm': isolated outlier\(s\) at rows 52, 53"):
        load_measured_series(_write(tmp_path / "s.csv", cols), sample_time_s=0.2)


def test_hampel_keeps_steps_ramps_and_noise():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 10, 501)
    for x in (np.where(t > 5, 1.0, 0.0), 3 * t, np.sin(t) + 1e-3 * rng.standard_normal(t.size)):
        assert hampel_outliers(x).size == 0
    x = np.sin(t)
    x[250] += 2.0  # a spike twice the signal's amplitude
    assert hampel_outliers(x).tolist() == [250]


def test_the_shipped_load_rejection_passes_the_checks(shipped_rejection):
    """No false alarm on a large, fast, genuine transient (44 % overspeed, vanes closing at the rate limit)."""
    r = shipped_rejection
    cols = {"time_s": r.time_s, "speed_rpm": r.speed_rpm, "head_m": r.head_m, "opening": r.opening,
            "torque_nm": r.torque_nm, "flow_m3_s": r.flow_m3_s}
    check_measured_table("timeseries.csv", cols, np.arange(r.time_s.size) + 2, sample_time_s=0.2)


def _op(**kw):
    base = dict(speed_rpm=200.0, head_m=176.0, flow_m3_s=97.0, torque_nm=7.3e6, opening=0.68)
    return OperatingPoint(**(base | kw))


@pytest.mark.parametrize("field, value, match", [
    ("speed_rpm", 200 * 2 * math.pi / 60, "it looks like rad/s; the column must be in r/min"),
    ("speed_rpm", 200 / 60, "it looks like r/s"),
    ("flow_m3_s", 97e3, "it looks like l/s"),
    ("torque_nm", 7.3e3, r"it looks like kN\*m"),
    ("head_m", 17.3, "it looks like bar"),
    ("speed_rpm", 1e4, r"expected 0.2 to 5 x rated"),
])
def test_units_are_checked_against_the_plant(field, value, match):
    plant = load_plant(PLANT)
    check_against_plant("s.csv", _op(), plant)  # the shipped plant's own operating point passes
    with pytest.raises(InputError, match=rf"s.csv: column '{field}' starts at .*{match}"):
        check_against_plant("s.csv", _op(**{field: value}), plant)


def test_part_load_flow_and_torque_are_not_flagged():
    check_against_plant("s.csv", _op(flow_m3_s=20.0, torque_nm=5e5), load_plant(PLANT))


class _Series:
    def __init__(self, amplitude, n=600, tau=0.2, quiet=True):
        t = tau * np.arange(n)
        self.sample_time_s = tau
        self.y = amplitude * ((t > 5) & (t < 15))
        if not quiet:
            self.y = self.y + amplitude * (t > t[-1] - 10)  # a move within the last 100 s
        self.x = self.h = self.m = self.q = 0.5 * self.y


def test_small_signal_warning():
    assert small_signal_warning(_Series(0.01)) is None
    text = small_signal_warning(_Series(0.44))
    assert text.startswith("the series leaves the small-signal range: opening by 44 %, speed by 22 %")


def test_quiet_tail_is_reported_only_when_there_is_one():
    settings = ExperimentSettings()  # quiet_s 100 s = 500 samples at 0.2 s
    assert has_quiet_tail(_Series(0.01, n=600), settings)
    assert not has_quiet_tail(_Series(0.01, n=600, quiet=False), settings)
    assert not has_quiet_tail(_Series(0.01, n=400), settings)  # shorter than the tail


def _summary(theta, *, quiet_s=100.0):
    """A summary whose three recursive estimators found ``theta`` (ZOH structure, order 3) with huge errors."""
    huge = SimulationModeError(max_abs_error=332826844722642498355200.0, peak_abs_output=0.005,
                               relative_error=6.7e25)
    entry = ArxEstimate(theta=tuple(theta), updates=590, n_a=3, n_b=3, input_delay=0,
                        simulation_mode_final_theta=huge, simulation_mode_online=huge, theta_spread_quiet_tail=0.1,
                        step_error_vs_nets=3.3e23)
    ideal = CoefficientSet(ex=-1.0, ey=1.0, eh=1.5, eqx=0.0, eqy=1.0, eqh=0.5)
    return IdentificationSummary(
        source="measured", operating_point=_op(), experiment=ExperimentSettings(quiet_s=quiet_s), sample_time_s=0.2,
        samples=600, arx_structure=ArxStructure(n_a=3, n_b=3, input_delay=0), peak_abs_x=0.005,
        six_coefficients=SixCoefficientResult(batch_ls=ideal, condition_number=10.0, residual_rms=ResidualRms(0, 0)),
        arx=ArxResults(dead_zone_eps0=1e-7, forgetting_factor=0.98, rls_p0=1e10, rls=entry, rls_forgetting=entry,
                       dead_zone_rls=entry),
        step_response_horizon_s=26.0)


def test_unstable_model_is_said_not_printed_as_a_huge_number():
    """An unstable identified model is reported as unstable (it once printed 332826844722642498355200.0000)."""
    unstable = [2.1, -1.05, 0.0, 0.01, 0.0, 0.0]  # z^3 - 2.1 z^2 + 1.05 z: poles (2.1 +- sqrt(0.21)) / 2 and 0
    assert _summary(unstable).arx.rls.pole_modulus() == pytest.approx((2.1 + math.sqrt(0.21)) / 2, rel=1e-12)
    summary, notes = review_summary(_summary(unstable), _Series(0.01), ExperimentSettings())
    assert summary.arx.rls.stable is False and summary.arx.rls.max_pole_modulus > 1
    assert any("identified by rls is unstable (largest pole |z| = 1.279129 >= 1)" in n for n in notes)
    table = markdown_tables(summary)
    assert "| rls | unstable | unstable | 3.328e+23 | 0.1000 |" in table  # the on-line error is still a number
    stable_summary, notes = review_summary(_summary([1.5, -0.56, 0.0, 0.01, 0.0, 0.0]), _Series(0.01),
                                           ExperimentSettings())  # poles 0.8 and 0.7
    assert notes == [] and stable_summary.arx.rls.stable is True
    assert stable_summary.arx.rls.max_pole_modulus == pytest.approx(0.8, rel=1e-12)
    assert "| rls | 3.300e+23 | 3.328e+23 |" in markdown_tables(stable_summary)  # huge but stable: readable
    # the review is recorded in the JSON, next to the estimate it judged
    entry = to_json_dict(summary)["arx"]["rls"]
    assert entry["stable"] is False and list(entry)[-3:] == ["step_error_vs_nets", "max_pole_modulus", "stable"]


def test_no_quiet_tail_is_recorded():
    summary, notes = review_summary(_summary([1.5, -0.56, 0.0, 0.01, 0.0, 0.0]), _Series(0.01, quiet=False),
                                    ExperimentSettings())
    assert notes[-1].startswith("no quiet tail (the opening moves within the last 100 s")
    assert summary.arx.rls.theta_spread_quiet_tail is None and summary.experiment.quiet_s == 0.0
    data = to_json_dict(summary)
    assert data["arx"]["rls"]["theta_spread_quiet_tail"] is None  # null, not left out: the field always exists
    assert "| rls | 3.300e+23 | 3.328e+23 | 3.328e+23 | - |" in markdown_tables(summary)
