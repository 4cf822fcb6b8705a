"""The identification comparison: settings, series handling, measured data, and (with the simulator) acceptance."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.linearize import COEFFICIENT_NAMES
from simulate.identification.experiment import ExperimentSettings
from simulate.identification.compare import identify_measured
from simulate.identification.tables import markdown_tables
from simulate.identification.measured import OperatingPoint, RelativeSeries, load_measured_series
from simulate.linear.models import LinearPlant

OP = OperatingPoint(speed_rpm=200.0, head_m=176.0, flow_m3_s=140.0, torque_nm=1.07e7, opening=0.68)
PLANT = LinearPlant(ex=-1.08, ey=0.42, eh=1.54, eqx=-0.03, eqy=0.50, eqh=0.515, water_time_s=1.4,
                    inertia_time_s=9.0, self_regulation=1.0, wave_time_s=0.44)


def linear_measurement(settings: ExperimentSettings, *, fine: int = 4):
    """A 'measured' series from the linear plant itself (no simulator): exact ZOH at tau / fine, the opening
    schedule of ``settings``, m and q from eqs. (4)-(5); returned in physical units about OP."""
    tau = settings.sample_time_s / fine
    times, levels = settings.opening_schedule()
    n = int(round(settings.duration_s / tau))
    t = tau * np.arange(n + 1)
    y = np.zeros(n + 1)
    for time, level in zip(times, levels):
        y[t >= time - 1e-9] = level
    ss = PLANT.state_space()
    states = ss.discretize(tau).simulate(y[:-1])
    x, h = states[:, 0], ss.head(states, y)
    m = PLANT.ex * x + PLANT.ey * y + PLANT.eh * h  # eq. (4)
    q = PLANT.eqx * x + PLANT.eqy * y + PLANT.eqh * h  # eq. (5)
    return dict(time_s=t, speed_rpm=OP.speed_rpm * (1 + x), head_m=OP.head_m * (1 + h),
                opening=OP.opening * (1 + y), torque_nm=OP.torque_nm * (1 + m), flow_m3_s=OP.flow_m3_s * (1 + q))


SHORT = ExperimentSettings(step_hold_s=20.0, prbs_duration_s=60.0, quiet_s=20.0)


def write_csv(path, data, columns=("time_s", "speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s")):
    arr = np.column_stack([data[c] for c in columns])
    np.savetxt(path, arr, delimiter=",", header=",".join(columns), comments="", fmt="%.15g")
    return path


# ---------------------------------------------------------------------------------------------------------------
# settings and schedule
# ---------------------------------------------------------------------------------------------------------------


def test_schedule_is_on_the_sample_grid_seeded_and_sized():
    s = ExperimentSettings()
    times, levels = s.opening_schedule()
    np.testing.assert_allclose(times / s.sample_time_s, np.round(times / s.sample_time_s), atol=1e-9)
    assert list(levels[:4]) == [0.01, 0.0, -0.01, 0.0]  # the +-1 % steps
    assert set(np.round(levels[4:-1], 12)) == {0.01, -0.01} and levels[-1] == 0.0
    again, _ = ExperimentSettings().opening_schedule()
    other, _ = ExperimentSettings(seed=1).opening_schedule()
    np.testing.assert_array_equal(times, again)  # deterministic for a seed
    assert times.size != other.size or np.any(times != other)  # and the seed matters
    assert times[-1] < s.duration_s - s.quiet_s + 1e-9


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("sample_time_s", 0.0, "experiment.sample_time_s must be a number in \\(0.0, 10.0\\]"),
        ("step_amplitude", 0.5, "experiment.step_amplitude"),
        ("noise_level", -1e-3, "experiment.noise_level"),
        ("forgetting_factor", 1.2, "experiment.forgetting_factor"),
        ("rls_p0", float("nan"), "experiment.rls_p0"),
        ("dead_zone_eps0", -1.0, "experiment.dead_zone_eps0"),
        ("seed", -1, "experiment.seed must be an integer >= 0"),
        ("seed", 1.5, "experiment.seed"),
        ("arx_structure", "armax", "experiment.arx_structure must be 'zoh' or 'paper'"),
        ("prbs_bit_s", 0.1, "experiment.prbs_bit_s must be >= sample_time_s"),
        ("quiet_s", "10", "experiment.quiet_s must be a number"),
    ],
)
def test_bad_settings_are_rejected(field, value, match):
    with pytest.raises(InputError, match=match):
        ExperimentSettings(**{field: value})


def test_no_excitation_is_rejected():
    with pytest.raises(InputError, match="no excitation"):
        ExperimentSettings(step_amplitude=0.0, prbs_amplitude=0.0)


# ---------------------------------------------------------------------------------------------------------------
# series
# ---------------------------------------------------------------------------------------------------------------


def test_resampling_is_linear_interpolation_and_relative_to_the_operating_point():
    t = np.linspace(0.0, 10.0, 101)  # 0.1 s
    ramp = 1.0 + 0.01 * t
    s = RelativeSeries.from_physical(t, 200 * ramp, 176 * ramp, 0.5 * ramp, 1e7 * ramp, 140 * ramp,
                                     sample_time_s=0.25)
    assert s.time_s[1] == 0.25 and s.x.size == 41
    np.testing.assert_allclose(s.x, 0.01 * s.time_s, atol=1e-14)  # interpolating a ramp is exact
    np.testing.assert_allclose(s.q, s.y, atol=1e-14)
    assert s.operating_point.speed_rpm == 200.0  # default O: the first sample


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.__setitem__("time_s", d["time_s"][::-1]), "strictly increasing"),
        (lambda d: d["head_m"].__setitem__(3, np.nan), "head_m contains a non-finite value at row 3"),
        (lambda d: d.__setitem__("flow_m3_s", d["flow_m3_s"][:-1]), "flow_m3_s must have as many samples"),
    ],
)
def test_bad_physical_series_are_rejected(mutate, match):
    d = linear_measurement(SHORT)
    mutate(d)
    with pytest.raises(InputError, match=match):
        RelativeSeries.from_physical(**d, sample_time_s=0.2)


def test_bad_operating_point_is_rejected():
    with pytest.raises(InputError, match="operating point torque_nm must be finite and > 0"):
        OperatingPoint(speed_rpm=200.0, head_m=176.0, flow_m3_s=140.0, torque_nm=0.0, opening=0.5)


def test_noise_is_seeded_bounded_and_spares_the_opening():
    s = RelativeSeries.from_physical(**linear_measurement(SHORT), sample_time_s=0.2, operating_point=OP)
    a, b = s.with_noise(1e-4, 3), s.with_noise(1e-4, 3)
    np.testing.assert_array_equal(a.x, b.x)
    assert 0 < np.max(np.abs(a.x - s.x)) <= 1e-4 and np.array_equal(a.y, s.y)


# ---------------------------------------------------------------------------------------------------------------
# measured data path (no simulator: the 'plant' is the linear model itself, so everything is exact)
# ---------------------------------------------------------------------------------------------------------------


def test_identify_measured_recovers_the_linear_plant_exactly(tmp_path):
    path = write_csv(tmp_path / "series.csv", linear_measurement(SHORT))
    series = load_measured_series(path, sample_time_s=0.2, operating_point=OP)
    report = identify_measured(series, SHORT)
    six = report.summary.six_coefficients.batch_ls
    # m and q are exact linear functions of (x, h, y): LS reproduces the coefficients to round-off
    np.testing.assert_allclose([getattr(six, k) for k in COEFFICIENT_NAMES],
                               [getattr(PLANT, k) for k in COEFFICIENT_NAMES], atol=1e-9)
    # the samples at tau of an exact ZOH simulation at tau/4 are an exact ZOH simulation at tau: RLS finds the
    # plant's own ARX up to its ridge bias |theta| / (p0 lambda_min(phi^T phi)) (see test_identify)
    from simulate.identification.estimators import arx_regressors

    arx_true = PLANT.arx(0.2)
    phi, _ = arx_regressors(series.x, series.y, n_a=3, n_b=3, input_delay=0)
    bias = np.linalg.norm(arx_true.theta) / (SHORT.rls_p0 * np.linalg.eigvalsh(phi.T @ phi).min())
    assert bias < 0.01
    np.testing.assert_allclose(report.summary.arx.rls.theta, arx_true.theta, atol=2 * bias)
    sim = report.summary.arx.rls.simulation_mode_final_theta
    assert sim.relative_error < 1e-3  # only the small ridge bias of theta remains (measured 1.4e-4)
    paths = report.write(tmp_path / "out")
    data = json.loads(paths["json"].read_text())
    assert data["source"] == "measured" and "acceptance" not in data  # no nets reference given
    for key in ("series_png", "six_png", "theta_png", "simulation_mode_png"):
        assert paths[key].stat().st_size > 5_000
    assert "| ex |" in markdown_tables(report.summary)


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty file"),
        ("time_s,speed_rpm,head_m,opening,torque_nm\n1,2,3,4,5\n", r"missing column\(s\) \['flow_m3_s'\]"),
        ("time_s,speed_rpm,head_m,opening,torque_nm,flow_m3_s\n" + "0,1,1,1,1,1\n" * 3, "at least 10 data rows"),
        ("time_s,speed_rpm,head_m,opening,torque_nm,flow_m3_s\n0,1,1,x,1,1\n", "row 2, column 'opening': not a number"),
        ("time_s,speed_rpm,head_m,opening,torque_nm,flow_m3_s\n0,1,1,1\n", "row 2 has 4 fields"),
        ("time_s,speed_rpm,head_m,opening,torque_nm,flow_m3_s\n"
         + "".join(f"{i % 3},1,1,1,1,1\n" for i in range(12)), "strictly increasing"),
    ],
)
def test_bad_measured_csv_is_rejected(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        load_measured_series(path, sample_time_s=0.2)


def test_missing_measured_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot read series file"):
        load_measured_series(tmp_path / "nope.csv", sample_time_s=0.2)


def test_measured_csv_accepts_extra_columns_in_any_order(tmp_path):
    d = linear_measurement(SHORT)
    d["power_mw"] = np.zeros_like(d["time_s"])
    cols = ("power_mw", "flow_m3_s", "time_s", "opening", "speed_rpm", "torque_nm", "head_m")
    series = load_measured_series(write_csv(tmp_path / "s.csv", d, cols), sample_time_s=0.2, operating_point=OP)
    np.testing.assert_allclose(series.x[:50], (d["speed_rpm"][::4][:50] / OP.speed_rpm - 1), atol=1e-12)


def test_summary_is_a_frozen_record_and_the_json_is_made_from_it(tmp_path):
    import dataclasses

    from simulate.identification.results import to_json_dict

    path = write_csv(tmp_path / "series.csv", linear_measurement(SHORT))
    report = identify_measured(load_measured_series(path, sample_time_s=0.2, operating_point=OP), SHORT)
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.summary.samples = 3
    data = json.loads(report.write(tmp_path / "out")["json"].read_text())
    assert data == to_json_dict(report.summary) == report.to_dict()
    # the file keeps its keys and order; sections that do not apply (no nets reference) are left out
    assert list(data)[:5] == ["source", "operating_point", "experiment", "sample_time_s", "samples"]
    assert "nets" not in data["six_coefficients"] and "nets_zoh" not in data["arx"]
    assert "step_error_vs_nets" not in data["arx"]["rls"] and "arma_paper002" not in data
    # a None that is a value (the automatic dead zone of the settings) is written as null
    assert data["experiment"]["dead_zone_eps0"] is None
    assert data["arx"]["rls"]["theta"] == list(report.summary.arx.rls.theta)
    assert data["six_coefficients"]["batch_ls"]["eqh"] == report.summary.six_coefficients.batch_ls.eqh
