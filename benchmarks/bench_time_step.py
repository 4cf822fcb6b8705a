"""Step convergence of the chosen time step: every shipped plant, every scenario kind, at the step the solver chooses
and at half of it (twice ``penstock.reaches`` for MOC, half ``solver.dt_s`` otherwise;
:func:`simulate.studies.step_check.check_step`).

    PYTHONPATH=$PWD python benchmarks/bench_time_step.py [--markdown docs/time-step.md]

Prints one row per (plant, kind): the step, the sub-steps per step, what limited the step, max speed rise and max
head rise and their change at half the step, in points of percent. The bound the docs state is 0.1 point.
``--markdown`` writes the table with the command into that file (docs/time-step.md is generated so).
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path

#: Largest accepted change of max speed rise and max head rise at half the step, points of percent.
BOUND_POINTS = 0.1
#: The shipped plant files a run takes (plant_hla339_guarantee.toml is the input of `hillsim guarantee`).
PLANTS = ("plant_hla339.toml", "plant_hla339_grid.toml", "plant_hla339_surge_tank.toml")
#: One scenario per kind (30 s, event at 1 s; the electrical tests 3 s with the event at 0.5 s).
SCENARIOS = {
    "load-rejection": {"t_end_s": 30.0, "initial_power_mw": 225.0, "event_time_s": 1.0},
    "closure-law": {"t_end_s": 30.0, "initial_power_mw": 225.0, "event_time_s": 1.0, "closing_time_s": 10.0},
    "frequency-steps": {"t_end_s": 30.0, "speed_steps": [0.04], "step_times_s": [1.0]},
    "load-step": {"t_end_s": 30.0, "initial_power_mw": 180.0, "event_time_s": 1.0, "load_step": -0.1},
    "opening-steps": {"t_end_s": 30.0, "initial_power_mw": 180.0, "opening_steps": [0.05], "step_times_s": [1.0]},
    "short-circuit": {"t_end_s": 3.0, "event_time_s": 0.5},
    "field-step": {"t_end_s": 3.0, "event_time_s": 0.5, "field_step_pu": 0.1},
}


def plant_with_scenario(path, kind: str):
    """The plant file at ``path`` with the scenario of :data:`SCENARIOS` for ``kind``; None when the plant cannot
    run that kind (the electrical tests need the sub-transient generator)."""
    from hillchart.errors import InputError
    from simulate.config import load_plant, plant_from_dict, to_dict

    raw = to_dict(load_plant(path))
    raw["scenario"] = {"kind": kind, **SCENARIOS[kind]}
    try:
        return plant_from_dict(raw, base_dir=Path(path).parent)
    except InputError as exc:
        if "needs generator.model" in str(exc) or "steps the island load" in str(exc):
            return None
        raise


def table_rows():
    from simulate.loop.engine import run_simulation
    from simulate.studies.step_check import check_step

    rows = []
    for name in PLANTS:
        path = resources.files("data_synthetic") / name
        for kind in SCENARIOS:
            plant = plant_with_scenario(path, kind)
            if plant is None:
                continue
            result = run_simulation(plant)
            check = check_step(plant, result)
            fig = check["figures"]
            rows.append((name, kind, result.meta["dt_s"], result.meta["substeps"], result.meta["dt_limited_by"],
                         100 * fig["max_speed_rise"]["value"], fig["max_speed_rise"]["change"],
                         100 * fig["max_head_rise"]["value"], fig["max_head_rise"]["change"]))
    return rows


def markdown(rows) -> str:
    lines = ["| plant | scenario | dt (s) | sub-steps | step set by | max speed rise (%) | change at dt/2 (points) "
             "| max head rise (%) | change at dt/2 (points) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r[0]} | {r[1]} | {r[2]:.5g} | {r[3]} | {r[4]} | {r[5]:.3f} | {r[6]:+.4f} | {r[7]:.3f} | "
                     f"{r[8]:+.4f} |")
    worst = max(max(abs(r[6]), abs(r[8])) for r in rows)
    lines.append("")
    lines.append(f"Largest change: {worst:.4f} points (bound {BOUND_POINTS} point).")
    return "\n".join(lines) + "\n"


DOC_HEAD = """# The time step

hillsim chooses the time step from the time scales of the plant's components (`simulate/loop/timestep.py`): the rotor's
inertia time, the governor's servo, derivative filter and integral time, the generator's sub-transient and transient
constants and its excitation filter, the surge tank's period, and the penstock model's own condition (the water
time Tw for the rigid, lumped and z-domain models; none for the method of characteristics, which is exact on its
grid). A step resolves a time scale T when dt <= 0.1 T (0.05 T for the governor's derivative filter, discretized
by implicit Euler: first order where the servo is an exact exponential). `solver.substeps` fixes the sub-steps.

* **MOC**: the step is the grid's, (shortest travel time) / `penstock.reaches`. The governor, the rotor and the
  generator advance in sub-steps of at most 0.1 x their fastest time scale inside it. The rotor's inertia time and a
  surge tank's period meet the hydraulics once per step: a grid too coarse for them is a warning (above 0.1 T) or an
  error (above 0.5 T) naming `penstock.reaches`.
* **rigid, lumped, z-domain** without `solver.dt_s`: the largest step at most the MOC grid's and 0.1 x every time
  scale, shortened so that the scenario's events fall on a step (an event at t happens at t).
* **`solver.dt_s` set**: that step; each time scale it does not resolve is a warning naming the component, its
  time constant and the key.

`hillsim run PLANT --out DIR --check-step` reruns the scenario at half the step and reports the change of each
summary figure (also in `summary.json`, `step_check`).

## Step convergence of the shipped plants

Every shipped plant with each scenario kind it can run (30 s, event at 1 s; the electrical tests 3 s, event at
0.5 s), at the chosen step and at half of it. Regenerate with:

    PYTHONPATH=$PWD python benchmarks/bench_time_step.py --markdown docs/time-step.md

"""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", type=Path, help="write the page (docs/time-step.md) with the table")
    args = parser.parse_args(argv)
    rows = table_rows()
    table = markdown(rows)
    print(table, end="")
    if args.markdown is not None:
        args.markdown.write_text(DOC_HEAD + table, encoding="utf-8")
    worst = max(max(abs(r[6]), abs(r[8])) for r in rows)
    return 0 if worst < BOUND_POINTS else 1


if __name__ == "__main__":
    sys.exit(main())
