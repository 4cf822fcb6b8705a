"""Pressure-loop study: iterations per step and failures of the three turbine-boundary solvers.

Cases: a full closure to a = 0 (closure-law, 10 s full-stroke closure from rated power) and no-load operation
(frequency-steps, +4/-8/+4 % at 10/40/70 s), on the shipped HLA339-like plant with its nets and with the ideal
turbine, for the MOC and rigid penstocks and relaxation alpha = 1.0 and 0.5. A failure stops the run; the table
gives the time of the first failure.

Run:  PYTHONPATH=$PWD OMP_NUM_THREADS=1 python benchmarks/bench_pressure_loop.py
"""

from __future__ import annotations

from importlib import resources

import numpy as np

from simulate.config import load_plant
from simulate.loop.engine import run_simulation

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"
CASES = {
    "closure to a=0": {"scenario.kind": "closure-law", "scenario.closing_time_s": 10.0, "scenario.t_end_s": 30.0},
    "no-load steps": {"scenario.kind": "frequency-steps", "scenario.t_end_s": 100.0},
}


def table() -> str:
    """The markdown table: one row per turbine, penstock, case, loop and relaxation."""
    lines = ["| turbine | penstock | case | loop | alpha | result | mean it/step | max it/step | steps with > 10 it |",
             "|---|---|---|---|---|---|---|---|---|"]
    for turbine in ("francis/nets.json", "ideal"):
        for model in ("moc", "rigid"):
            for case, overrides in CASES.items():
                for loop in ("improved", "traditional", "newton"):
                    for alpha in ((1.0, 0.5) if loop != "newton" else (1.0,)):
                        plant = load_plant(PLANT_FILE, {**overrides, "turbine.characteristics": turbine,
                                                        "penstock.model": model, "solver.pressure_loop": loop,
                                                        "solver.relaxation": alpha,
                                                        "solver.fallback": False})  # the loop alone
                        r = run_simulation(plant, raise_on_failure=False)
                        it = r.iterations[1:]
                        solved = it[it > 0]  # steps with the vanes shut need no iteration
                        status = "ok" if r.success else f"FAILS at t = {r.time_s[-1] + r.meta['dt_s']:.2f} s"
                        mean = f"{solved.mean():.2f}" if solved.size else "-"
                        top = int(solved.max()) if solved.size else 0
                        name = "nets" if turbine != "ideal" else "ideal"
                        lines.append(f"| {name} | {model} | {case} | {loop} | {alpha} | {status} | {mean} | {top} | "
                                     f"{int(np.sum(solved > 10))} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    print(table(), end="")


if __name__ == "__main__":
    main()
