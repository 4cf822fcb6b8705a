"""Per-step cost of the assembled loop (the component loop against the old monolithic one).

    PYTHONPATH=$PWD OMP_NUM_THREADS=1 python benchmarks/bench_loop_step.py [--repeat 15] [--substeps N] [--hydraulic]
        [--friction brunone]

60 s load rejection of the shipped plant, 3147 steps, for the nets and the ideal turbine on the MOC penstock and the
ideal turbine on the rigid one. ``--hydraulic``: a hydraulic-only run instead (the closure-law scenario: the vanes
follow a prescribed 10 s closure, no governor), whose step and cost depend on the penstock alone. Prints the loop's
wall time (``SimulationResult.wall_time_s``: the compiled loop and its chunk driver, nothing else), best and median of
``--repeat`` runs after one warm-up run, and ns per step. ``--friction NAME``: each MOC case also with
``penstock.friction_model = NAME``, and the ratio of its best wall time to the steady model's.
"""

from __future__ import annotations

import argparse
import os
import statistics
from importlib import resources

from simulate.components.registry import FRICTION
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

PLANT_FILE = resources.files("data_synthetic") / "plant_hla339.toml"
CASES = (("francis/nets.json", "moc"), ("ideal", "moc"), ("ideal", "rigid"))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--substeps", type=int, help="pin solver.substeps (default: chosen by the solver)")
    parser.add_argument("--hydraulic", action="store_true", help="closure-law scenario (no governor)")
    parser.add_argument("--friction", choices=FRICTION.names()[1:],
                        help="each MOC case also with this friction model, and its cost over the steady one's")
    args = parser.parse_args(argv)
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"load average {load[0]:.2f}; best / median of {args.repeat}")
    print("| turbine | penstock | friction | steps | loop wall best / median (ms) | ns per step (best) | "
          "over steady |")
    print("|---|---|---|---|---|---|---|")
    for turbine, penstock in CASES:
        scenario = {"scenario.kind": "closure-law", "scenario.closing_time_s": 10.0} if args.hydraulic else {}
        frictions = ("steady", args.friction) if args.friction and penstock == "moc" else ("steady",)
        steady_best = None
        for friction in frictions:
            plant = load_plant(PLANT_FILE, {"turbine.characteristics": turbine, "penstock.model": penstock,
                                            "scenario.t_end_s": 60.0, **scenario,
                                            **({} if friction == "steady" else {"penstock.friction_model": friction}),
                                            **({} if args.substeps is None else {"solver.substeps": args.substeps})})
            steps = run_simulation(plant).time_s.size - 1  # warm-up: loads (or compiles) the loop
            walls = [run_simulation(plant).wall_time_s for _ in range(args.repeat)]
            best, median = min(walls), statistics.median(walls)
            steady_best = best if steady_best is None else steady_best
            shown = friction if penstock == "moc" else "-"
            print(f"| {turbine} | {penstock} | {shown} | {steps} | {1e3 * best:.3f} / {1e3 * median:.3f} "
                  f"| {1e9 * best / steps:.0f} | {best / steady_best:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
