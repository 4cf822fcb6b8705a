"""A double-regulated bulb rejection against a Francis rejection: wall time of the compiled loop, same run.

The 60 s load rejection of ``data_synthetic/plant_bulb.toml`` (three-input nets, guide vanes and blades, intake and
draft tube by MOC) and of ``data_synthetic/plant_hla339.toml`` (two-input nets, penstock by MOC), each run once to
compile (reported apart) and then timed best and median of 7 rounds that run the two in turn (interleaved, so
that on a shared machine both meet the same load). Besides the wall time per run, the time per step
compares the loops themselves (the two plants have different steps). The whole run (``run_simulation``: reading
the nets, steady state, building the components, the loop) is reported too; the bulb's cam is computed on the
first call (in its column) and found again by the nets' numbers on the repeated runs, as in a study that runs the
same nets many times.

Run:  PYTHONPATH=$PWD OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/bench_bulb.py [--repeats N]
"""

from __future__ import annotations

import argparse
import statistics
import time

from data_synthetic import PLANT_BULB, PLANT_HLA339
from simulate.config import load_plant
from simulate.loop.engine import run_simulation


def measure(paths: dict, repeats: int) -> dict:
    """Each plant's first call, then ``repeats`` rounds that run every plant once in turn (interleaved: on a shared
    machine both plants meet the same load)."""
    plants, firsts, out = {}, {}, {}
    for name, path in paths.items():
        plants[name] = load_plant(path, {"scenario.t_end_s": 60.0})
        t0 = time.perf_counter()
        first = run_simulation(plants[name])
        firsts[name] = (first, time.perf_counter() - t0)
    loops = {name: [] for name in paths}
    totals = {name: [] for name in paths}
    for _ in range(repeats):
        for name, plant in plants.items():
            t0 = time.perf_counter()
            loops[name].append(run_simulation(plant).wall_time_s)
            totals[name].append(time.perf_counter() - t0)
    for name, (first, first_call) in firsts.items():
        steps = first.time_s.size - 1
        out[name] = {"steps": steps, "dt_s": first.meta["dt_s"], "first_call_s": first_call,
                     "loop_best_s": min(loops[name]), "loop_median_s": statistics.median(loops[name]),
                     "total_median_s": statistics.median(totals[name]),
                     "us_per_step": 1e6 * statistics.median(loops[name]) / steps}
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    runs = measure({"bulb (double regulated, draft tube)": PLANT_BULB, "Francis (HLA339)": PLANT_HLA339},
                   args.repeats)
    print("| 60 s load rejection | steps | dt (s) | first call incl. compile (s) | loop best / median (ms) | "
          "us per step | whole run, median (ms) |")
    print("|---|---|---|---|---|---|---|")
    for name, r in runs.items():
        print(f"| {name} | {r['steps']} | {r['dt_s']:.4g} | {r['first_call_s']:.2f} | {1e3 * r['loop_best_s']:.2f} / "
              f"{1e3 * r['loop_median_s']:.2f} | {r['us_per_step']:.3f} | {1e3 * r['total_median_s']:.1f} |")
    bulb, francis = runs.values()
    print(f"\nbulb / Francis: loop wall time {bulb['loop_median_s'] / francis['loop_median_s']:.2f}, "
          f"per step {bulb['us_per_step'] / francis['us_per_step']:.2f}, "
          f"whole run {bulb['total_median_s'] / francis['total_median_s']:.2f}")


if __name__ == "__main__":
    main()
