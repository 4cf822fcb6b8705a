"""The two probes behind the batch engine's limits (docs/design-studies.md "What this machine allows") measure what
they say: the loop the floor benchmark times alone is the run's own loop, and the stacked grid equals moc_step."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation
from simulate.loop.generator import UNIT_SERIES
from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[3]


def _bench(name: str):
    """The benchmark script as a module registered under its name: numba's disk cache reloads a compiled function
    by importing its module, which fails (``No module named '<dynamic>'``) for a module absent from sys.modules."""
    return load_script(name)


@pytest.mark.slow
def test_the_floor_benchmark_times_the_runs_own_loop():
    bench = _bench("bench_batch_floor")
    plant = load_plant(PLANT_HLA339, {"scenario.t_end_s": 6.0})
    chars = load_characteristics(plant.turbine, plant.base_dir)
    captured = bench.capture_loop(plant, chars)
    reference = run_simulation(plant, characteristics=chars)
    args = copy.deepcopy(captured["args"])
    status, k = captured["loop"](0, captured["n_steps"], captured["dt"], captured["n_sub"], captured["stride"], *args)
    assert (status, k) == (0, captured["n_steps"])
    # out_units[row, unit, series] (simulate.loop.generator's time_loop arguments; series as UNIT_SERIES)
    out_units = args[3]
    speed, head = out_units[:, 0, UNIT_SERIES.index("speed_rpm")], out_units[:, 0, UNIT_SERIES.index("head_m")]
    # the same loop on the same arguments in one process: the same operations, so the same bits
    assert np.array_equal(speed, reference.speed_rpm) and np.array_equal(head, reference.head_m)
    assert speed.max() > speed[0] * 1.05  # a rejection ran, not a copy of the initial state
    # the captured arguments are the initial state, not the finished run's
    assert np.all(captured["args"][3][1:] == 0.0)


def test_the_stacked_grid_equals_moc_step_to_the_bit():
    bench = _bench("bench_stacked_layout")
    from simulate.components.hydraulic.penstock import build_moc_grid, moc_steady_state

    plant = load_plant(PLANT_HLA339)
    grid = build_moc_grid(plant.penstock, plant.time_step_s)
    heads0, flows0 = moc_steady_state(grid, plant.penstock.static_head_m, plant.turbine.rated_flow_m3_s)
    cases, steps = 8, 40
    turbine_head = heads0[-1] * (1.0 + 0.01 * np.arange(cases))
    turbine_flow = flows0[-1] * (1.0 - 0.02 * np.arange(cases))

    def run(friction):
        h, q = np.empty((2, heads0.size, cases)), np.empty((2, heads0.size, cases))
        h[0], q[0] = heads0[:, None], flows0[:, None]
        bench.run_stacked(h, q, grid.impedance_s_m2, friction, plant.penstock.static_head_m, turbine_head,
                          turbine_flow, steps)
        return h[0].T, q[0].T

    hc, qc = np.empty((cases, 2, heads0.size)), np.empty((cases, 2, heads0.size))
    hc[:, 0], qc[:, 0] = heads0, flows0
    bench.run_case_by_case(hc, qc, grid.impedance_s_m2, grid.friction_s2_m5, plant.penstock.static_head_m,
                           turbine_head, turbine_flow, steps)
    h, q = run(grid.friction_s2_m5)
    assert np.array_equal(h, hc[:, 0]) and np.array_equal(q, qc[:, 0])
    assert np.ptp(h[:, -2]) > 1.0  # the cases differ: each carries its own boundary (metres next to the turbine)
    # the comparison sees a change of 1e-12 in one reach's friction
    nudged = grid.friction_s2_m5.copy()
    nudged[3] *= 1.0 + 1e-12
    h, q = run(nudged)
    assert not np.array_equal(q, qc[:, 0])
    assert np.max(np.abs(q - qc[:, 0])) == pytest.approx(0.0, abs=1e-9)  # ...and it is only round-off
