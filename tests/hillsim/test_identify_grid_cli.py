"""``hillsim identify --head-model / --closed-loop-kp`` (paper 000 head model and closed-loop identification)."""

import json

import pytest

from data_synthetic import PLANT_HLA339
from hillsim.cli import main

SHORT = ["--penstock-model", "lumped", "--initial-opening", "0.68", "--step-hold-s", "20", "--prbs-duration-s", "40",
         "--quiet-s", "20"]


def test_identify_writes_head_model_and_closed_loop(tmp_path, capsys):
    out = tmp_path / "ident"
    argv = ["identify", str(PLANT_HLA339), "--out", str(out), *SHORT, "--head-model", "interval",
            "--closed-loop-kp", "2.94", "--closed-loop-ti", "5"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "head model (interval)" in text and "closed loop Kp 2.94, TI 5.0 s: stable" in text
    head = json.loads((out / "head_model.json").read_text())
    # the same bounds as tests/simulate/identification/test_head_model.py on a shorter experiment (measured 1-2 %)
    assert max(head["errors_fraction_of_peak"].values()) < 0.03
    assert (out / "head_model.png").stat().st_size > 20_000
    runs = json.loads((out / "closed_loop.json").read_text())
    assert len(runs) == 1 and runs[0]["closed_loop_stable"] is True
    assert runs[0]["linear_closed_loop"]["reference_prbs"]["step_error"] < 1e-9


@pytest.mark.parametrize("extra, message", [
    (["--closed-loop-kp", "-1"], "--closed-loop-kp must be a number in (0, 1000]"),
    (["--closed-loop-kp", "7.5", "--closed-loop-ti", "0.5", "0"], "--closed-loop-ti values must be numbers"),
    (["--closed-loop-kp", "nan"], "--closed-loop-kp must be a number in (0, 1000], got nan"),
    # integral times alone would be ignored (no closed-loop run without Kp): refused, naming what to add
    (["--closed-loop-ti", "0"], "--closed-loop-ti 0 needs --closed-loop-kp"),
])
def test_bad_head_and_closed_loop_options_leave_nothing(extra, message, tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["identify", str(PLANT_HLA339), "--out", str(out), *extra]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()  # rejected before anything is written
