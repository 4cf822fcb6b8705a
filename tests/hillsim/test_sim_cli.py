"""``hillsim run``: output files and columns, --set overrides, errors printed with exit code 2."""

import csv
import json
from importlib import resources

import numpy as np
import pytest

from hillsim.cli import main
from simulate.results.result import CSV_COLUMNS

PLANT_FILE = str(resources.files("data_synthetic") / "plant_hla339.toml")
SUMMARY_KEYS = ("max_speed_rise", "t_max_speed_s", "max_head_rise", "min_head_drop", "final_speed_error",
                "mean_iterations", "max_iterations")


def test_run_writes_timeseries_summary_and_plot(tmp_path, capsys):
    out = tmp_path / "run1"
    code = main(["run", PLANT_FILE, "--out", str(out), "--set", "turbine.characteristics=\"ideal\"",
                 "--set", "scenario.t_end_s=6", "--set", "penstock.model=zdomain"])
    assert code == 0
    assert "load-rejection" in capsys.readouterr().out
    with open(out / "timeseries.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == CSV_COLUMNS  # exactly the documented columns, in order
    data = np.array(rows[1:], dtype=float)
    # the z-domain model's step: 0.05 x the governor's derivative filter (0.2 s), shortened to put the rejection (2 s)
    # on a step: 2 s / 200
    dt = 2.0 / 200
    assert data.shape == (int(round(6.0 / dt)) + 1, len(CSV_COLUMNS))
    assert data[1, 0] == pytest.approx(dt, abs=1e-6)
    assert data[0, 1] == pytest.approx(200.0) and data[0, 8] == 0 and data[1:, 8].min() >= 1
    assert np.allclose(data[:, 5], data[:, 4] * 32.0, rtol=1e-8)  # chart opening = stroke * opening_max
    # power = torque * omega
    assert np.allclose(data[:, 7], data[:, 6] * data[:, 1] * 2 * np.pi / 60 * 1e-6, rtol=1e-8)
    summary = json.loads((out / "summary.json").read_text())
    for key in SUMMARY_KEYS:
        assert key in summary
    assert summary["penstock_model"] == "zdomain" and summary["success"] is True
    assert summary["max_speed_rise"] == pytest.approx(data[:, 1].max() / 200.0 - 1, rel=1e-8)
    png = (out / "transient.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


@pytest.mark.parametrize("args,message", [
    (["--set", "solver.dt_s=0.05", "--set", "turbine.characteristics=ideal"],
     "does not meet the MOC Courant condition"),
    (["--set", "penstock.wave_speed=1000"], "unknown key penstock.wave_speed"),
    (["--set", "governor.kp=-1"], "governor.kp must be in [0.0, 1000.0], got -1.0"),
    (["--set", "turbine.characteristics=\"missing/nets.json\""], "turbine.characteristics = 'missing/nets.json'"),
    (["--set", "nonsense"], "--set expects section.key=value"),
])
def test_bad_input_prints_error_and_exits_2(tmp_path, capsys, args, message):
    code = main(["run", PLANT_FILE, "--out", str(tmp_path / "x"), *args])
    assert code == 2
    err = capsys.readouterr().err
    last = err.splitlines()[-1]  # progress lines (a start line on a non-terminal) may precede it
    assert last.startswith("hillsim run: error: ") and message in last and "Traceback" not in err


def test_pressure_loop_failure_writes_partial_series_and_exits_2(tmp_path, capsys):
    out = tmp_path / "fail"
    code = main(["run", PLANT_FILE, "--out", str(out), "--no-plot", "--set", "turbine.characteristics=\"ideal\"",
                 "--set", "solver.pressure_loop=\"traditional\"", "--set", "solver.fallback=false",
                 "--set", "scenario.t_end_s=5"])
    assert code == 2
    assert "failed (no convergence)" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] is False and not (out / "transient.png").exists()
