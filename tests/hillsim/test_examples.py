"""The documented Python example runs and prints physically sensible numbers."""

import re
import runpy
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "quickstart.py"


def test_quickstart_runs(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sys, "argv", [str(EXAMPLE), str(tmp_path)])
    runpy.run_path(str(EXAMPLE), run_name="__main__")
    out = capsys.readouterr().out
    assert (tmp_path / "timeseries.csv").is_file() and (tmp_path / "extended.csv").is_file()
    rise = float(re.search(r"max speed rise ([0-9.]+)%", out).group(1))
    assert 5 < rise < 80  # a full load rejection overspeeds the unit, but a governed one stays below 80 %
    rigid = float(re.search(r"rigid water column: max head rise ([0-9.]+)%", out).group(1))
    elastic = float(re.search(r"max head rise ([0-9.]+)%", out).group(1))
    assert rigid > 0 and elastic > 0
