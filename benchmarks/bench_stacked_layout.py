"""What a loop with the case index innermost would gain: the MOC grid and the flow net, per case and step.

    PYTHONPATH=$PWD python benchmarks/bench_stacked_layout.py [--cases 1,4,16,64,256] [--steps 20000]

A probe of a data layout, not a simulator: the shipped plant's grid (23 reaches at its 19 ms step) advanced for a
stack of cases, each with its own turbine head and flow, two ways:

- *case by case*: the simulator's own :func:`simulate.components.hydraulic.penstock.moc_step` on each case's
  (2, nodes) arrays, as the loop runs a case today;
- *stacked*: the same operations in the same order on (nodes, cases) arrays, the case index innermost, which the
  compiler turns into vector instructions. The stacked results are checked equal to the bit to moc_step's after
  every run (the probe exits non-zero otherwise).

Then the flow net's value (:func:`hillchart.nets.weights._net_value_grad` of the shipped nets) for a stack of
points, one call per point: its eight exponentials are scalar library calls here (numba has no vector math library
on this machine, ``numba -s``), so it costs the same per point in either layout. The points follow a smooth path
over the chart, as a run's do.

Prints ns per case and step and the ratio. The grid is about a quarter of a shipped-plant step (about 350 ns);
see docs/design-studies.md "What this machine allows" for what the rest of a step costs.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numba
import numpy as np

from data_synthetic import PLANT_HLA339
from hillchart.nets.weights import _net_value_grad
from simulate.components.hydraulic.penstock import build_moc_grid, moc_step, moc_steady_state
from simulate.config import load_characteristics, load_plant
from simulate.components.turbine.evaluation import compile_characteristics


@numba.njit(cache=True)
def stacked_step(heads, flows, impedance, friction, reservoir_m, turbine_head_m, turbine_flow_m3_s, new_heads,
                 new_flows):
    """moc_step's operations on (nodes, cases) arrays, the case index innermost (the layout probe)."""
    n = heads.shape[0] - 1
    b0 = impedance[0]
    for c in range(heads.shape[1]):
        c_m = heads[1, c] - b0 * flows[1, c] + friction[0] * flows[1, c] * abs(flows[1, c])
        new_heads[0, c] = reservoir_m
        new_flows[0, c] = (reservoir_m - c_m) / b0
    for j in range(1, n):
        bl, br, rl, rr = impedance[j - 1], impedance[j], friction[j - 1], friction[j]
        h_l, q_l, h_r, q_r = heads[j - 1], flows[j - 1], heads[j + 1], flows[j + 1]
        h_new, q_new = new_heads[j], new_flows[j]
        for c in range(heads.shape[1]):
            c_p = h_l[c] + bl * q_l[c] - rl * q_l[c] * abs(q_l[c])
            c_m = h_r[c] - br * q_r[c] + rr * q_r[c] * abs(q_r[c])
            q = (c_p - c_m) / (bl + br)
            q_new[c] = q
            h_new[c] = c_p - bl * q
    for c in range(heads.shape[1]):
        new_heads[n, c] = turbine_head_m[c]
        new_flows[n, c] = turbine_flow_m3_s[c]


@numba.njit(cache=True)
def run_stacked(heads, flows, impedance, friction, reservoir_m, turbine_head_m, turbine_flow_m3_s, steps):
    """``steps`` (even) steps on the (2, nodes, cases) pair of buffers; the result is in buffer 0."""
    for k in range(steps):
        cur = k & 1
        stacked_step(heads[cur], flows[cur], impedance, friction, reservoir_m, turbine_head_m, turbine_flow_m3_s,
                     heads[1 - cur], flows[1 - cur])


@numba.njit(cache=True)
def run_case_by_case(heads, flows, impedance, friction, reservoir_m, turbine_head_m, turbine_flow_m3_s, steps):
    """The same on (cases, 2, nodes) buffers, one case after the other through moc_step."""
    for c in range(heads.shape[0]):
        for k in range(steps):
            cur = k & 1
            moc_step(heads[c, cur], flows[c, cur], impedance, friction, reservoir_m, turbine_head_m[c],
                     turbine_flow_m3_s[c], heads[c, 1 - cur], flows[c, 1 - cur])


@numba.njit(cache=True)
def net_values(p, n11, opening, out):
    for k in range(n11.size):
        out[k] = _net_value_grad(p, n11[k], opening[k])[0]


def grid_row(impedance, friction, heads0, flows0, reservoir_m, cases: int, steps: int, repeat: int):
    rng = np.random.default_rng(cases)
    turbine_flow = flows0[-1] * (1.0 + 0.1 * rng.random(cases))  # each case its own boundary
    turbine_head = heads0[-1] * (1.0 + 0.02 * rng.random(cases))
    nodes = heads0.size

    def stacked():
        h = np.empty((2, nodes, cases))
        q = np.empty((2, nodes, cases))
        h[0], q[0] = heads0[:, None], flows0[:, None]
        return h, q

    def separate():
        h = np.empty((cases, 2, nodes))
        q = np.empty((cases, 2, nodes))
        h[:, 0], q[:, 0] = heads0, flows0
        return h, q

    times = {"stacked": [], "case by case": []}
    for _ in range(repeat):
        hs, qs = stacked()
        t0 = time.perf_counter()
        run_stacked(hs, qs, impedance, friction, reservoir_m, turbine_head, turbine_flow, steps)
        times["stacked"].append(time.perf_counter() - t0)
        hc, qc = separate()
        t0 = time.perf_counter()
        run_case_by_case(hc, qc, impedance, friction, reservoir_m, turbine_head, turbine_flow, steps)
        times["case by case"].append(time.perf_counter() - t0)
        if not (np.array_equal(hs[0].T, hc[:, 0]) and np.array_equal(qs[0].T, qc[:, 0])):
            sys.exit("the stacked grid differs from moc_step's: the probe is wrong")
    return {k: 1e9 * min(v) / (cases * steps) for k, v in times.items()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="1,4,16,64,256")
    parser.add_argument("--steps", type=int, default=20000, help="steps per timing (even)")
    parser.add_argument("--repeat", type=int, default=5, help="timings per row (best reported)")
    args = parser.parse_args(argv)
    steps = args.steps + args.steps % 2
    plant = load_plant(PLANT_HLA339)
    grid = build_moc_grid(plant.penstock, plant.time_step_s)
    flow0 = plant.turbine.rated_flow_m3_s
    reservoir_m = plant.penstock.static_head_m
    heads0, flows0 = moc_steady_state(grid, reservoir_m, flow0)
    impedance, friction = grid.impedance_s_m2, grid.friction_s2_m5
    print(f"shipped plant's grid: {impedance.size} reaches; best of {args.repeat}; equal to the bit: checked")
    print()
    print("| cases in the stack | case by case (moc_step), ns per case-step | stacked, ns per case-step | ratio |")
    print("|---|---|---|---|")
    grid_row(impedance, friction, heads0, flows0, reservoir_m, 4, 2, 1)  # compile or load
    for cases in (int(c) for c in args.cases.split(",")):
        row = grid_row(impedance, friction, heads0, flows0, reservoir_m, cases, max(2, steps // cases // 2 * 2),
                       args.repeat)
        print(f"| {cases} | {row['case by case']:.1f} | {row['stacked']:.1f} | "
              f"{row['case by case'] / row['stacked']:.2f} |")

    chars = compile_characteristics(load_characteristics(plant.turbine, plant.base_dir))
    flow_net = chars.params[0]
    points = 200_000
    phase = np.linspace(0.0, 40.0 * np.pi, points)  # a smooth path over the chart, as a run's points follow each other
    n11 = 85.0 + 25.0 * np.sin(phase)
    opening = 16.0 + 14.0 * np.cos(0.7 * phase)
    out = np.empty(points)
    net_values(flow_net, n11[:10], opening[:10], out[:10])
    walls = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        net_values(flow_net, n11, opening, out)
        walls.append(time.perf_counter() - t0)
    print(f"\nflow net ({int(flow_net[0])} hidden neurons), value at {points} points: "
          f"{1e9 * min(walls) / points:.0f} ns a point (median {1e9 * statistics.median(walls) / points:.0f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
