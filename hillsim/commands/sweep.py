"""``hillsim sweep plant.toml --vary KEY=START:STOP:COUNT --vary KEY=v1,v2 [--cases cases.csv] --out DIR
[--scheduler local|dask [ADDRESS]]``: run the Cartesian product of the varied values as one batch.

Writes ``DIR/results.csv`` (one row per case), ``DIR/sweep.json`` and ``DIR/sweep.png``.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from hillchart.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep", help="run a plant's scenario over a grid of values (batched, local cores or Dask)",
        description="Run the plant's scenario for every combination of the --vary values (and/or every row of "
                    "--cases) and write results.csv, sweep.json and sweep.png into --out. A failing case is a row "
                    "with its error; when every case failed the files are written and the exit code is 2.")
    parser.add_argument("plant", type=Path, help="plant TOML file")
    parser.add_argument("--vary", action="append", default=[], metavar="KEY=START:STOP:COUNT|KEY=v1,v2,...",
                        help="a numeric plant key and its values: COUNT evenly spaced values with both ends "
                             "included, or a list (repeatable; the sweep is the Cartesian product); or a key that "
                             "selects a model (penstock.model, solver.pressure_loop, scenario.kind, "
                             "turbine.characteristics) and a list of names: the cases are grouped by them")
    parser.add_argument("--cases", type=Path, default=None, metavar="CASES.CSV",
                        help="one column per key (section.key header), one row of numbers (or model names) per "
                             "case")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    parser.add_argument("--scheduler", nargs="+", default=["local"], metavar="local|dask [ADDRESS]",
                        help="local cores (default) or Dask: a LocalCluster, or the scheduler at ADDRESS "
                             "(tcp://HOST:PORT); Dask needs pip install 'hillsim[dask]'")
    parser.add_argument("--workers", type=int, default=None, help="parallel workers (default: available cores)")
    parser.add_argument("--chunk-size", type=int, default=None, help="cases per task (default: automatic)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant-file key for every case (as in hillsim run)")
    parser.add_argument("--no-plot", action="store_true", help="do not write sweep.png")
    parser.add_argument("--allow-large", action="store_true",
                        help=f"run a sweep of more than {LARGE_SWEEP_CASES} cases or {LARGE_SWEEP_STEPS:.0e} time "
                             "steps in all (refused otherwise, after the estimate is printed)")
    parser.set_defaults(func=sweep_command)


#: A sweep above either bound is refused unless --allow-large (hours of work started by a typo in COUNT).
LARGE_SWEEP_CASES = 20_000
LARGE_SWEEP_STEPS = 2e9


class Progress:
    """A progress bar on a terminal (stderr), nothing per case otherwise (the stage lines say enough)."""

    def __init__(self, stream=None, width: int = 40):
        self.stream = sys.stderr if stream is None else stream
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.width = width

    def __call__(self, done: int, total: int) -> None:
        if not self.tty or total <= 0:
            return
        filled = int(self.width * done / total)
        self.stream.write(f"\r[{'#' * filled}{'.' * (self.width - filled)}] {done}/{total} cases")
        if done >= total:
            self.stream.write("\n")
        self.stream.flush()


def parse_scheduler(values: list[str]) -> tuple[str, str | None]:
    """``["local"]``, ``["dask"]`` or ``["dask", ADDRESS]`` -> (scheduler, address)."""
    kind = values[0]
    if kind not in ("local", "dask"):
        raise InputError(f"--scheduler must be local or dask [ADDRESS], got {kind!r}")
    if len(values) > 2 or (kind == "local" and len(values) > 1):
        raise InputError(f"--scheduler takes local, dask or dask ADDRESS; got {' '.join(values)!r}")
    return kind, (values[1] if len(values) == 2 else None)


def cap_workers(workers: int | None, option: str = "--workers") -> int | None:
    """``workers`` capped at the cores this process may use (a warning on stderr says so): more local workers than
    cores only slow each other down and multiply the memory."""
    from simulate.studies.batch import default_workers

    cores = default_workers()
    if workers is not None and workers > cores:
        print(f"warning: {option} {workers} is more than the {cores} core(s) available; using {cores}",
              file=sys.stderr)
        return cores
    return workers


def sweep_command(args: argparse.Namespace) -> int:
    from hillsim.commands import load_command_plant
    from simulate.studies.sweep import build_variants, run_sweep, write_sweep

    scheduler, address = parse_scheduler(args.scheduler)
    for name in ("workers", "chunk_size"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise InputError(f"--{name.replace('_', '-')} must be an integer >= 1, got {value}")
    if scheduler == "local":
        args.workers = cap_workers(args.workers)
    out = args.outputs.folder("--out", args.out)  # checked and locked now, moved into place when complete
    plant = load_command_plant("sweep", args.plant, args.overrides)
    with warnings.catch_warnings(record=True) as caught:  # how a spreadsheet's --cases file was read
        warnings.simplefilter("always")
        variants = build_variants(plant, args.vary, args.cases)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    where = f"Dask {'LocalCluster' if address is None else address}" if scheduler == "dask" else "local cores"
    steps = len(variants) * max(1, round(plant.scenario.t_end_s / plant.time_step_s))
    estimate = f"{len(variants)} cases of about {steps // len(variants)} time steps ({steps:.3g} steps in all)"
    if (len(variants) > LARGE_SWEEP_CASES or steps > LARGE_SWEEP_STEPS) and not args.allow_large:
        raise InputError(f"the sweep has {estimate}, more than {LARGE_SWEEP_CASES} cases or {LARGE_SWEEP_STEPS:.0e} "
                         "steps (hours of computing); reduce COUNT or the values, or add --allow-large")
    print(f"sweep: {len(variants)} cases on {where} (about {steps // len(variants)} time steps each, {steps:.3g} in "
          "all)", flush=True)
    batch = run_sweep(plant, variants, scheduler=scheduler, address=address, workers=args.workers,
                      chunk_size=args.chunk_size, progress=Progress())
    statuses = [c.status for c in batch.cases]
    print(f"sweep: ran {len(batch.cases)} cases in {batch.wall_time_s:.2f} s ({batch.mechanism}, {batch.workers} "
          f"workers): {statuses.count('ok')} ok, {statuses.count('failed')} failed, {statuses.count('error')} "
          f"errors, {sum(bool(c.extrapolated) for c in batch.cases)} extrapolated", flush=True)
    paths = write_sweep(batch, out, plant_file=str(args.plant), plot=not args.no_plot,
                        extra={"vary": list(args.vary), "cases_file": None if args.cases is None else str(args.cases),
                               "overrides": list(args.overrides)})
    print(f"sweep: wrote {', '.join(p.name for p in paths.values())} to {args.out}")
    if "ok" not in statuses:  # nothing to compare: a failure (exit 2), with the record of why each case failed
        from hillchart.errors import NumericalError

        args.outputs.commit()  # results.csv holds each case's error (as hillsim run keeps the series of a failure)
        first = batch.cases[0]
        raise (NumericalError if "failed" in statuses else InputError)(
            f"every one of the {len(statuses)} cases failed, none ran to the end (case 0, {first.status}: "
            f"{(first.error.splitlines() or [''])[0]}); the error of each case is in {args.out}/results.csv")
    return 0
