"""Simulation speed: real-time factor (simulated s per wall s) and steps/s of the 60 s example
load rejection with the MOC penstock, compiled loop, one core. Compile time (first call in a process) is reported
separately; the timed runs are the best and median of 7.

Run:  PYTHONPATH=$PWD OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/bench_sim_speed.py
"""

from __future__ import annotations

import statistics
import time
from importlib import resources

from simulate.config import load_plant
from simulate.loop.engine import run_simulation

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"


def main() -> None:
    print("| turbine | pressure loop | MOC reaches | dt (s) | steps | first call incl. compile (s) | "
          "loop wall best / median (ms) | real-time factor (best / median) | steps/s (median) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for turbine in ("francis/nets.json", "ideal"):
        for loop in ("improved", "newton", "traditional"):
            for reaches in (8, 32):
                overrides = {"turbine.characteristics": turbine, "solver.pressure_loop": loop,
                             "penstock.reaches": reaches, "scenario.t_end_s": 60.0}
                if loop == "traditional":
                    overrides["solver.relaxation"] = 0.5  # alpha = 1 diverges on this plant
                plant = load_plant(PLANT_FILE, overrides)
                t0 = time.perf_counter()
                first = run_simulation(plant)
                first_call = time.perf_counter() - t0
                walls = [run_simulation(plant).wall_time_s for _ in range(7)]
                best, med = min(walls), statistics.median(walls)
                steps = first.time_s.size - 1
                sim_s = first.time_s[-1]
                name = "nets" if turbine != "ideal" else "ideal"
                print(f"| {name} | {loop} | {reaches} | {first.meta['dt_s']:.5f} | {steps} | {first_call:.2f} | "
                      f"{1e3 * best:.2f} / {1e3 * med:.2f} | {sim_s / best:,.0f} / {sim_s / med:,.0f} | "
                      f"{steps / med:,.0f} |")


if __name__ == "__main__":
    main()
