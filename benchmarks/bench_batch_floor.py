"""What this machine allows a batch of the shipped plant: the floors under the batch engine's throughput.

    PYTHONPATH=$PWD python benchmarks/bench_batch_floor.py [--cases 400] [--repeat 3] [--sweep 1000]

Two floors, each measured on this machine in this run, beside what the batch engine reaches:

1. **The compiled loop alone.** The shipped plant's 60 s load rejection (nets, MOC, 3147 steps) is run once to
   capture the arguments of its compiled time loop; then ``--cases`` fresh copies of them (made before the clock
   starts) go through the loop with no Python around it: no plant variant, steady state, components' build, time-step
   plan or figures. On one process, and split over two forked processes (the cores of this machine). No batch engine
   that keeps this loop can do more; ``run_batch`` of the same number of cases (processes) runs beside it.
2. **A whole process.** Fresh interpreters: ``python -c pass``; ``import numba``; ``import numba`` and the first
   call of a one-line function that numba loads from its disk cache (numba initialises its compiler at the first
   compiled call, loaded or compiled: the simulator's loop pays it too); a ``hillsim sweep`` of 2 closing times
   (everything a sweep does before and after its cases) and one of ``--sweep`` closing times. No process that runs a
   numba-compiled loop can start in less than the third.

Prints case-steps per second and each figure's ratio to the goals of the batched engine (5e6 case-steps/s on 2
cores; a whole 1000-case ``hillsim sweep`` at 4e6, i.e. within 3147 x 1000 / 4e6 = 0.79 s). Medians of
``--repeat``; the machine is a shared virtual machine, so compare the rows of one run only.
"""

from __future__ import annotations

import argparse
import copy
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from data_synthetic import PLANT_HLA339
from simulate.config import load_characteristics, load_plant
from simulate.loop import driver, engine
from simulate.studies.batch import run_batch

ROOT = Path(__file__).resolve().parents[1]
GOAL_BATCH = 5e6  # case-steps/s on 2 cores
GOAL_SWEEP = 4e6  # case-steps/s of a whole hillsim sweep process

_LOOP: dict = {}


def capture_loop(plant, chars) -> dict:
    """The compiled loop of ``plant`` and its arguments, taken from a run (the driver's chunk runner is wrapped
    for that one run; the benchmark's only intrusion)."""
    original = driver.run_in_chunks
    captured = {}

    def grab(loop, args, n_steps, dt, n_sub, stride, progress=None):
        captured.update(loop=loop, args=copy.deepcopy(args), n_steps=n_steps, dt=dt, n_sub=n_sub, stride=stride)
        return original(loop, args, n_steps, dt, n_sub, stride, progress)

    driver.run_in_chunks = grab
    try:
        result = engine.run_simulation(plant, characteristics=chars)
    finally:
        driver.run_in_chunks = original
    assert result.success
    return captured


def _run_copies(bounds) -> int:
    """Worker: the loop over the copies ``bounds = (lo, hi)`` (made in the parent before the fork)."""
    lo, hi = bounds
    c = _LOOP
    for args in c["copies"][lo:hi]:
        status, _ = c["loop"](0, c["n_steps"], c["dt"], c["n_sub"], c["stride"], *args)
        if status != 0:
            raise RuntimeError(f"the loop failed (status {status})")
    return hi - lo


def loop_alone(n: int, processes: int) -> float:
    """Case-steps/s of the captured loop over ``n`` fresh copies of its arguments, on 1 or 2 processes."""
    _LOOP["copies"] = [copy.deepcopy(_LOOP["args"]) for _ in range(n)]
    if processes == 1:
        start = time.perf_counter()
        _run_copies((0, n))
        wall = time.perf_counter() - start
    else:
        with multiprocessing.get_context("fork").Pool(processes) as pool:
            pool.map(_run_copies, [(0, 0)] * processes)  # the workers exist before the clock starts
            shares = np.linspace(0, n, processes + 1).astype(int)
            start = time.perf_counter()
            pool.map(_run_copies, list(zip(shares[:-1], shares[1:])))
            wall = time.perf_counter() - start
    _LOOP["copies"] = []  # not kept: a million small objects would slow the batches' garbage collection
    return n * _LOOP["n_steps"] / wall


def process_wall(cmd: list[str], env: dict) -> float:
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return time.perf_counter() - start


def _cached_function(folder: str) -> Path:
    """A script whose one-line function numba caches on disk (in ``folder``) and calls."""
    script = Path(folder) / "cached_function.py"
    script.write_text("import numba\n\n\n@numba.njit(cache=True)\ndef one_more(x):\n    return x + 1\n\n\n"
                      "one_more(1)\n")
    return script


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=400, help="cases of the loop-alone and batch rows")
    parser.add_argument("--repeat", type=int, default=3, help="timings per row (median reported)")
    parser.add_argument("--sweep", type=int, default=1000, help="closing times of the whole-process sweep")
    args = parser.parse_args(argv)
    plant = load_plant(PLANT_HLA339)
    chars = load_characteristics(plant.turbine, plant.base_dir)
    _LOOP.update(capture_loop(plant, chars))
    steps = _LOOP["n_steps"]
    load = os.getloadavg()
    print(f"{os.cpu_count()} cores; load average {load[0]:.2f}; shipped plant, {steps} steps a case; "
          f"median of {args.repeat}")
    print()
    variants = [{"governor.closing_time_s": float(v)} for v in np.linspace(8.0, 16.0, args.cases)]
    run_batch(plant, variants[:2], characteristics=chars, mechanism="serial")
    rows = {"compiled loop alone, 1 process": lambda: loop_alone(args.cases, 1),
            "compiled loop alone, 2 processes": lambda: loop_alone(args.cases, 2),
            "run_batch, serial": lambda: _batch(plant, chars, variants, "serial"),
            "run_batch, processes (2)": lambda: _batch(plant, chars, variants, "processes")}
    rates = {}
    for label, measure in rows.items():
        measure()  # warm-up (pages of the copies, the pool's first fork)
        rates[label] = statistics.median(measure() for _ in range(args.repeat))
    print(f"| {args.cases} cases | case-steps/s | / goal {GOAL_BATCH:.0e} |")
    print("|---|---|---|")
    for label, rate in rates.items():
        print(f"| {label} | {rate:.3g} | {rate / GOAL_BATCH:.2f} |")
    two = rates["compiled loop alone, 2 processes"]
    print(f"\ntwo processes / one: {two / rates['compiled loop alone, 1 process']:.2f}; run_batch (processes) / "
          f"the loop alone on 2 processes: {rates['run_batch, processes (2)'] / two:.2f}")

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    py = sys.executable
    budget = steps * args.sweep / GOAL_SWEEP
    with tempfile.TemporaryDirectory() as tmp:
        def sweep(n):
            return [py, "-m", "hillsim.cli", "sweep", str(PLANT_HLA339), "--vary",
                    f"governor.closing_time_s=8:16:{n}", "--out", tempfile.mkdtemp(dir=tmp), "--no-plot", "--quiet"]

        commands = {"python -c pass": [py, "-c", "pass"],
                    "python -c 'import numba'": [py, "-c", "import numba"],
                    "import numba, first call of a cached function": [py, str(_cached_function(tmp))],
                    "hillsim sweep, 2 cases": sweep(2),
                    f"hillsim sweep, {args.sweep} cases": sweep(args.sweep)}
        walls = {}
        for label, cmd in commands.items():
            process_wall(cmd, env)  # warm caches
            walls[label] = statistics.median(process_wall(cmd, env) for _ in range(args.repeat))
    print(f"\n| whole process | wall (s) | / the {args.sweep}-case sweep's budget at {GOAL_SWEEP:.0e} "
          f"({budget:.2f} s) |")
    print("|---|---|---|")
    for label, wall in walls.items():
        print(f"| {label} | {wall:.2f} | {wall / budget:.2f} |")
    whole = walls[f"hillsim sweep, {args.sweep} cases"]
    print(f"\nthe {args.sweep}-case sweep: {steps * args.sweep / whole:.3g} case-steps/s "
          f"({steps * args.sweep / whole / GOAL_SWEEP:.2f} of the goal)")
    return 0


def _batch(plant, chars, variants, mechanism) -> float:
    batch = run_batch(plant, variants, characteristics=chars, mechanism=mechanism, workers=2)
    assert batch.n_ok == len(variants)
    return batch.case_steps / batch.wall_time_s


if __name__ == "__main__":
    raise SystemExit(main())
