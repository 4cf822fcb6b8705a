"""Speed of a plant with several units: the loop wall time of a 60 s load rejection of the two-unit example plant
(``data_synthetic/plant_two_units.toml``: both units rejecting, and one of the two) against the single-unit example
plant (``plant_hla339.toml``) on the same step, compiled loops, one core. The timed runs are the best and median of
``--repeat`` after one warm-up run (which compiles or loads the loop from the cache); the ratio is of the best times
(the least disturbed by other jobs on a shared machine; the medians are printed beside).

Run:  PYTHONPATH=$PWD OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/bench_multi_unit.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics

from data_synthetic import PLANT_HLA339, PLANT_TWO_UNITS
from simulate.config import load_plant
from simulate.loop.engine import run_simulation


def nodes(plant) -> int:
    """MOC computing nodes of the plant's pipes (common conduit and branches) on its step."""
    from simulate.components.hydraulic.penstock import build_moc_grid

    dt = plant.time_step_s
    pipes = [plant.penstock] + [u.branch_penstock(plant.penstock) for u in plant.units]
    return sum(sum(build_moc_grid(p, dt).reaches_per_segment) + 1 for p in pipes)


def measure(plant, repeat: int):
    first = run_simulation(plant)  # warm-up: compiles the loop or loads it from numba's cache
    walls = [run_simulation(plant).wall_time_s for _ in range(repeat)]
    return first, min(walls), statistics.median(walls)


def rows(repeat: int = 7, turbines=("francis/nets.json", "ideal")) -> list[str]:
    out = ["| turbine | plant | units | MOC nodes | steps | loop wall best / median (ms) | us per step (median) | "
           "ratio to one unit (best) |", "|---|---|---|---|---|---|---|---|"]
    for turbine in turbines:
        name = "nets" if turbine != "ideal" else "ideal"
        cases = (("plant_hla339.toml (one unit)", PLANT_HLA339, {}),
                 ("plant_two_units.toml, U1 rejects", PLANT_TWO_UNITS, {}),
                 ("plant_two_units.toml, both reject", PLANT_TWO_UNITS, {"scenario.units": ["U1", "U2"]}))
        base = None
        for label, path, extra in cases:
            plant = load_plant(path, {"turbine.characteristics": turbine, "scenario.t_end_s": 60.0, **extra})
            first, best, med = measure(plant, repeat)
            steps = first.time_s.size - 1
            base = best if base is None else base
            out.append(f"| {name} | {label} | {max(1, len(plant.units))} | {nodes(plant)} | {steps} | "
                       f"{1e3 * best:.2f} / {1e3 * med:.2f} | {1e6 * med / steps:.2f} | {best / base:.2f} |")
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=7, help="timed runs per case (default 7)")
    args = parser.parse_args(argv)
    print("\n".join(rows(args.repeat)))


if __name__ == "__main__":
    main()
