"""Wall times a user sees: ``hillsim demo --fast``, ``hillsim train`` and the test suite's two tiers, median and
range of N runs.

    PYTHONPATH=. python benchmarks/bench_wall_times.py [--runs 3] [--skip-suite] [--skip-demo] [--skip-train]

``hillsim train`` (defaults: the ensemble of 10, the extension's model, its hypotheses weighed on held-out lines)
runs on the shipped chart and on the real charts found in the external data folder (``HILLSIM_EXTERNAL_DIR``, else
``../shared/external``): the Sayano-Shushenskaya Francis chart and the ZZ680 Kaplan chart's workbook (read with
openpyxl, when installed); ``hillsim fccm --simulator-nets`` (defaults: 5 members) on the real bulb rig's table. A
chart absent is named and skipped.

Prints one row per measurement with the median, min and max wall time, the CPU time (user + sys of the child
processes: less sensitive to other load than the wall time) and the 1-minute load average before each run, with the
date and the machine's core count, so the README's figures can be re-measured and compared. Quote the wall times only
from a quiet machine (load average well below the core count).
"""

from __future__ import annotations

import argparse
import datetime
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _timed(cmd: list[str], env: dict) -> tuple[float, float, float, int]:
    """(wall s, child CPU s, load average before, exit code) of one run."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr[-2000:])
    return wall, cpu, load, proc.returncode


def train_charts(folder: Path) -> list[tuple[str, Path]]:
    """(label, folder) of what ``hillsim train`` is timed on, the shipped chart and the real charts present, and of
    the table ``hillsim fccm --simulator-nets`` is (a folder with table.csv); written into ``folder``, the absent
    ones named on stderr."""
    from data_synthetic import FRANCIS_DIR
    from tests.external_charts import (EXTERNAL_DIR, SAYANO_CONTOURS, SAYANO_LINES, ZZ680_WORKBOOK,
                                       write_kaplan_workbook_chart, write_sayano_chart)
    from tests.fccm_external import BULB_137KW, write_bulb_137kw_table

    charts = [("shipped chart", Path(FRANCIS_DIR))]
    if all((EXTERNAL_DIR / name).is_file() for name in (SAYANO_LINES, SAYANO_CONTOURS)):
        charts.append(("Sayano-Shushenskaya", write_sayano_chart(folder / "sayano")))
    else:
        print(f"the Sayano-Shushenskaya chart is absent from {EXTERNAL_DIR}: not timed", file=sys.stderr)
    try:
        import openpyxl  # noqa: F401
    except ImportError:
        openpyxl = None
    if (EXTERNAL_DIR / ZZ680_WORKBOOK).is_file() and openpyxl is not None:
        charts.append(("ZZ680 Kaplan", write_kaplan_workbook_chart(EXTERNAL_DIR / ZZ680_WORKBOOK, folder / "zz680")))
    else:
        print(f"the ZZ680 workbook is absent from {EXTERNAL_DIR}, or openpyxl is not installed: not timed",
              file=sys.stderr)
    if (EXTERNAL_DIR / BULB_137KW).is_file():
        charts.append(("EGAT bulb table", write_bulb_137kw_table(folder / "bulb")))
    else:
        print(f"the bulb rig's table is absent from {EXTERNAL_DIR}: not timed", file=sys.stderr)
    return charts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--skip-suite", action="store_true")
    parser.add_argument("--skip-demo", action="store_true")
    parser.add_argument("--skip-train", action="store_true")
    args = parser.parse_args(argv)
    charts = tempfile.TemporaryDirectory()
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    cases = []
    if not args.skip_demo:
        cases.append(("hillsim demo --fast", lambda tmp: [sys.executable, "-m", "hillsim.cli", "demo", "--fast",
                                                          "--quiet", "--out", str(Path(tmp) / "demo")]))
    if not args.skip_train:
        for label, folder in train_charts(Path(charts.name)):
            if (folder / "table.csv").is_file():
                cases.append((f"hillsim fccm ({label})", lambda tmp, folder=folder: [
                    sys.executable, "-m", "hillsim.cli", "fccm", str(folder), "--simulator-nets", "--no-plots",
                    "--out", str(Path(tmp) / "fccm")]))
                continue
            cases.append((f"hillsim train ({label})", lambda tmp, folder=folder: [
                sys.executable, "-m", "hillsim.cli", "train", str(folder), "--out", str(Path(tmp) / "nets.json")]))
    if not args.skip_suite:
        suite = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
        cases.append(("pytest -q (fast tier)", lambda tmp: suite))
        cases.append(("pytest -q -m slow", lambda tmp: suite + ["-m", "slow"]))
    print(f"{datetime.date.today().isoformat()}, {os.cpu_count()} cores, {args.runs} runs each")
    print(f"{'what':<36} {'median s':>9} {'min s':>7} {'max s':>7} {'CPU s (median)':>15} {'load avg before':>16}")
    failed = False
    for label, make in cases:
        walls, cpus, loads = [], [], []
        for _ in range(args.runs):
            with tempfile.TemporaryDirectory() as tmp:
                wall, cpu, load, code = _timed(make(tmp), env)
            failed |= code != 0
            walls.append(wall)
            cpus.append(cpu)
            loads.append(load)
        print(f"{label:<36} {statistics.median(walls):>9.1f} {min(walls):>7.1f} {max(walls):>7.1f} "
              f"{statistics.median(cpus):>15.1f} {', '.join(f'{v:.2f}' for v in loads):>16}")
    charts.cleanup()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
