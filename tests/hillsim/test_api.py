"""The Python API and its outputs: lazy entry points in ``import hillsim``, SimulationResult.to_json with the
series, tidy floats in result files, one name for the forgetting factor."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hillsim
from hillchart.io.tidy import tidy_float, tidy_floats

REPO = Path(__file__).resolve().parents[2]


def test_import_hillsim_is_light():
    code = ("import sys, hillsim; heavy = [m for m in ('numpy', 'torch', 'numba', 'scipy', 'matplotlib') "
            "if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": ""}).stdout.strip()
    assert out == "[]"


def test_entry_points_resolve_to_the_defining_functions():
    from hillchart.nets.hill_nets import load_nets
    from simulate.loop.engine import run_simulation

    assert hillsim.load_nets is load_nets and hillsim.run_simulation is run_simulation
    for name in hillsim.ENTRY_POINTS:
        assert callable(getattr(hillsim, name)), name
        assert name in dir(hillsim) and name in hillsim.__doc__
    with pytest.raises(AttributeError, match="no attribute 'load_chrat'"):
        hillsim.load_chrat  # noqa: B018


def test_to_json_can_carry_the_series(tmp_path):
    from simulate.results.result import CSV_COLUMNS, SimulationResult

    t = np.array([0.0, 0.5, 1.0])
    r = SimulationResult(t, t + 200, t + 100, t, t, t, t, t, np.array([0, 3, 2]), 200.0, 200.0)
    plain = json.loads(r.to_json(tmp_path / "s.json").read_text())
    full = json.loads(r.to_json(tmp_path / "f.json", series=True).read_text())
    assert "series" not in plain and {k: v for k, v in full.items() if k != "series"} == plain
    assert tuple(full["series"]) == tuple(sorted(CSV_COLUMNS))  # sort_keys
    assert full["series"]["speed_rpm"] == [200.0, 200.5, 201.0] and full["series"]["iterations"] == [0, 3, 2]


def test_tidy_floats_rounds_noise_and_keeps_meaningful_digits():
    assert tidy_float(8.999999999999988) == 9.0 and tidy_float(0.9999999999999987) == 1.0
    assert tidy_float(3.719570726996532e-111) == 0.0 and tidy_float(5e-324) == 0.0  # noise and a subnormal
    assert tidy_float(4e-16) == 4e-16  # a steady-state residual is a result, not noise
    assert tidy_float(0.42172345678912345) == 0.421723456789
    assert np.isnan(tidy_float(float("nan"))) and tidy_float(float("inf")) == float("inf")
    assert tidy_floats({"a": (np.float64(1.0000000000000002), np.int64(3)), "b": [True, None]}) == \
        {"a": [1.0, 3], "b": [True, None]}


@pytest.mark.slow
def test_demo_result_files_have_tidy_floats(demo_fast_dir):
    """Result files hold tidy floats, never "inertia_time_s": 8.999999999999988 or
    "final_opening": 3.719570726996532e-111."""
    for file in ("linearization.json", "load_rejection/summary.json", "identification/identification.json"):
        data = json.loads((demo_fast_dir / file).read_text())
        assert tidy_floats(data) == data, file
    assert '"inertia_time_s": 9.0,' in (demo_fast_dir / "linearization.json").read_text()


def test_forgetting_factor_has_one_name():
    from hillsim.cli import build_parser

    parser = build_parser()
    a = parser.parse_args(["identify", "p.toml", "--out", "o", "--forgetting-factor", "0.9"])
    b = parser.parse_args(["identify", "p.toml", "--out", "o", "--forgetting", "0.9"])  # the old spelling works
    assert a.forgetting == b.forgetting == 0.9
    assert parser.parse_args(["identify", "p.toml", "--out", "o"]).p0 == 1e10


def test_summary_json_has_tidy_floats(tmp_path):
    """summary.json holds tidy floats, never "final_opening": 3.719570726996532e-111."""
    from simulate.results.result import SimulationResult

    t = np.array([0.0, 0.5, 1.0])
    opening = np.array([0.68, 0.3, 3.719570726996532e-111])
    power = np.array([225.00000000000028, 100.0, 0.0])
    r = SimulationResult(t, t + 200, t + 100, t, opening, t, t, power, np.array([0, 3, 2]), 200.0, 200.0)
    data = json.loads(r.to_json(tmp_path / "s.json").read_text())
    assert data["final_opening"] == 0.0 and data["initial_power_mw"] == 225.0
    assert r.summary()["final_opening"] == 3.719570726996532e-111  # the in-memory summary keeps full precision
