"""The branched valve network against TSNet (optional: skipped without ``pip install tsnet``); the comparison is
``benchmarks/bench_tsnet_branches.py``."""

from pathlib import Path

import numpy as np
import pytest
from tests.scripts import load_script

pytest.importorskip("tsnet")

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def bench():
    return load_script("bench_tsnet_branches")


def test_heads_at_the_valves_agree_with_tsnet(bench):
    before = sorted(p.name for p in Path.cwd().iterdir())
    data = bench.compare()
    assert sorted(p.name for p in Path.cwd().iterdir()) == before  # EPANET's temporary files stay in its folder
    assert data["rows"] == 400 and data["dt_s"][0] == pytest.approx(data["dt_s"][1], rel=1e-12)
    for node, fig in data["nodes"].items():
        # 0.5 m: the bound asked of the comparison (two MOC codes on one grid with the same friction factors; TSNet
        # stores heads in single precision); the closure's surge is ~37 m, so the bound is ~1 % of it
        assert fig["max_abs_diff_m"] <= bench.TOLERANCE_M, (node, fig)
    # a real transient: the closing valve's head rises by tens of metres
    assert data["nodes"]["J2"]["tsnet_max_m"] - 98.6 > 20.0


def test_the_comparison_can_fail(bench, tmp_path):
    """The same network with the open valve closing too is far from TSNet's run."""
    from dataclasses import replace

    from simulate.loop.engine import run_simulation

    ts = bench.run_tsnet(tmp_path)
    plant = bench.hillsim_plant(ts["friction"])
    plant = replace(plant, scenario=replace(plant.scenario, units=("V1", "V2")))
    both = run_simulation(plant, characteristics=bench.PrescribedFlowValve(100.0, 1.0))
    n = len(ts["heads"]["J3"])
    assert np.max(np.abs(both.units["V2"]["head_m"][:n] - ts["heads"]["J3"])) > 10 * bench.TOLERANCE_M
