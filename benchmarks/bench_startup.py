"""Start-up time of whole processes: wall time, median of N runs, warm and cold cache.

    python benchmarks/bench_startup.py [--repeat 5] [--cold 2]

Each command runs as a fresh process. "cold": an empty numba cache and loop cache (NUMBA_CACHE_DIR and
HILLSIM_CACHE_DIR point to a new temporary directory), so everything numba compiles is compiled; "warm": the same
directories again, so nothing is compiled. Prints one table row per command with the target of the issue and the
load average (timings on a shared machine are only indicative).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def commands(out_dir: Path) -> list[tuple[str, list[str], float]]:
    py = sys.executable
    return [
        ("hillsim run data_synthetic/plant_hla339.toml --out D",
         [py, "-m", "hillsim.cli", "run", "data_synthetic/plant_hla339.toml", "--out", str(out_dir / "run")], 2.0),
        ("hillsim linearize data_synthetic/francis/nets.json --n11 67.8 --opening 23.46",
         [py, "-m", "hillsim.cli", "linearize", "data_synthetic/francis/nets.json", "--n11", "67.8", "--opening",
          "23.46"], 1.0),
        ("python -c 'import simulate.loop.engine'", [py, "-c", "import simulate.loop.engine"], 1.0),
    ]


CPU: list[float] = []


def wall(cmd: list[str], env: dict) -> float:
    """Wall time of one process (its CPU time, user + sys, is appended to CPU: on a loaded machine it is the
    better estimate of the wall time on a quiet one, as the commands are single-threaded)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return elapsed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="warm runs per command (median reported)")
    parser.add_argument("--cold", type=int, default=2, help="cold-cache runs per command (median reported)")
    args = parser.parse_args(argv)
    base_env = dict(os.environ)
    base_env["PYTHONPATH"] = str(ROOT) + os.pathsep + base_env.get("PYTHONPATH", "")
    base_env.setdefault("MPLBACKEND", "Agg")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for label, cmd, target in commands(tmp):
            cold = []
            for i in range(args.cold):
                cache = tmp / f"cache-{len(rows)}-{i}"
                env = dict(base_env, NUMBA_CACHE_DIR=str(cache / "numba"), HILLSIM_CACHE_DIR=str(cache / "loops"))
                cold.append(wall(cmd, env))
            cold_cpu = statistics.median(CPU[-args.cold:])
            warm = [wall(cmd, env) for _ in range(args.repeat)]
            warm_cpu = statistics.median(CPU[-args.repeat:])
            rows.append((label, statistics.median(warm), min(warm), max(warm), warm_cpu, statistics.median(cold),
                         cold_cpu, target))
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; {os.cpu_count()} cores; median of {args.repeat} "
          f"warm / {args.cold} cold runs")
    print("| command | warm wall median (s) | warm wall range (s) | warm CPU median (s) | cold wall (s) | cold CPU (s) "
          "| target warm (s) | ratio warm wall/target |")
    print("|---|---|---|---|---|---|---|---|")
    for label, med, lo, hi, cpu, cold, cold_cpu, target in rows:
        print(f"| `{label}` | {med:.2f} | {lo:.2f}-{hi:.2f} | {cpu:.2f} | {cold:.2f} | {cold_cpu:.2f} | {target:.1f} "
              f"| {med / target:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
