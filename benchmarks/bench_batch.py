"""Batch throughput: case-steps per second of :func:`simulate.studies.batch.run_batch` on the
shipped plant (nets, MOC, 8 reaches, 60 s load rejection, 3147 steps a case) at N = 1, 10, 100, 1000 cases, against N
sequential ``run_simulation`` calls in one process (the same variants, plant built per case the same way).

Every mechanism is timed after the loop is compiled in this process (compile time is start-up, reported once).
Columns: case-steps/s of the whole call (plant variant, steady state, loop, figures), its ratio to the sequential
calls, and the loop-only rate of the sequential calls (sum of ``SimulationResult.wall_time_s``), which bounds what
one core can do. The load average is printed: the machine may be shared.

Run:  PYTHONPATH=$PWD python benchmarks/bench_batch.py [--sizes 1,10,100,1000] [--repeat 3]
      PYTHONPATH=$PWD python benchmarks/bench_batch.py --dask 1000    # local sweep vs two-worker LocalCluster

``--dask N``: an N-case sweep (closing time x initial power) locally and on a two-worker Dask ``LocalCluster``
(worker processes, so each compiles the loop once), checks that both results.csv are identical and prints the times.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from data_synthetic import PLANT_HLA339
from simulate.studies.batch import default_workers, run_batch
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation


def variants(n: int) -> list[dict]:
    """N evenly spaced governor closing times (8-16 s): every case a full, successful load rejection."""
    return [{"governor.closing_time_s": float(v)} for v in np.linspace(8.0, 16.0, n)]


def sequential(plant, chars, cases):
    steps, loop_wall = 0, 0.0
    t0 = time.perf_counter()
    for case in cases:
        result = run_simulation(plant.with_overrides(case), characteristics=chars)
        steps += result.time_s.size - 1
        loop_wall += result.wall_time_s
    return steps, time.perf_counter() - t0, loop_wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,10,100,1000")
    parser.add_argument("--repeat", type=int, default=3, help="timings per cell (median reported)")
    parser.add_argument("--dask", type=int, default=0, metavar="N", help="compare an N-case sweep local vs Dask")
    args = parser.parse_args()
    if args.dask:
        dask_compare(args.dask)
        return
    sizes = [int(s) for s in args.sizes.split(",")]
    plant = load_plant(PLANT_HLA339)
    chars = load_characteristics(plant.turbine, plant.base_dir)
    t0 = time.perf_counter()
    run_simulation(plant, characteristics=chars)
    compile_s = time.perf_counter() - t0
    workers = default_workers()
    print(f"cores available: {workers}; load average before: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} "
          f"{os.getloadavg()[2]:.2f}; first run in the process (compile) {compile_s:.2f} s")
    print()
    print("| N | sequential run_simulation (case-steps/s) | loop only, one core (steps/s) | batch serial | "
          "batch threads (2) | batch processes (2) | best / sequential |")
    print("|---|---|---|---|---|---|---|")
    for n in sizes:
        cases = variants(n)
        seq, loop = [], []
        for _ in range(args.repeat):
            steps, wall, loop_wall = sequential(plant, chars, cases)
            seq.append(steps / wall)
            loop.append(steps / loop_wall)
        rates = {}
        for mechanism in ("serial", "threads", "processes"):
            if mechanism != "serial" and n == 1:
                rates[mechanism] = float("nan")
                continue
            got = []
            for _ in range(args.repeat):
                batch = run_batch(plant, cases, characteristics=chars, mechanism=mechanism, workers=workers)
                assert batch.n_ok == n, [c.error for c in batch.cases if not c.ok][:1]
                got.append(batch.case_steps / batch.wall_time_s)
            rates[mechanism] = statistics.median(got)
        s = statistics.median(seq)
        best = np.nanmax(list(rates.values()))
        cells = " | ".join("-" if np.isnan(v) else f"{v:.3g}" for v in rates.values())
        print(f"| {n} | {s:.3g} | {statistics.median(loop):.3g} | {cells} | {best / s:.2f} |", flush=True)
    print()
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


def dask_compare(n: int) -> None:
    import tempfile
    from pathlib import Path

    from simulate.studies.sweep import build_variants, run_batch_dask

    plant = load_plant(PLANT_HLA339)
    side = max(1, int(round(n ** 0.5)))
    variants = build_variants(plant, [f"governor.closing_time_s=6:20:{side}",
                                      f"scenario.initial_power_mw=80:225:{max(1, -(-n // side))}"])
    print(f"{len(variants)} cases; load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    t0 = time.perf_counter()
    local = run_batch(plant, variants)
    t_local = time.perf_counter() - t0
    t0 = time.perf_counter()
    dask = run_batch_dask(plant, variants, n_workers=2, processes=True)
    t_dask = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        local.to_csv(Path(tmp) / "a.csv")
        dask.to_csv(Path(tmp) / "b.csv")
        same = (Path(tmp) / "a.csv").read_text() == (Path(tmp) / "b.csv").read_text()
    print(f"| cases | local ({local.mechanism}, {local.workers}) s | Dask LocalCluster (2 worker processes) s | "
          f"ok | identical results.csv |")
    print("|---|---|---|---|---|")
    print(f"| {len(variants)} | {t_local:.2f} | {t_dask:.2f} (incl. cluster start and compile in each worker) | "
          f"{local.n_ok} | {same} |")


if __name__ == "__main__":
    main()
