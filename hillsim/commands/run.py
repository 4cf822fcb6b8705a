"""``hillsim run plant.toml --out DIR [--set section.key=value ...]``: simulate a plant's scenario.

Writes ``DIR/timeseries.csv``, ``DIR/summary.json``, ``DIR/envelope.csv`` and the figures ``DIR/transient.png`` and
``DIR/envelope.png`` (all files are written by :func:`write_run_outputs`, after the simulation). Warnings (time step,
extrapolation outside the characteristics' trusted domain, column separation) go to stderr and into
``summary.json``. Ctrl-C stops the run within about a second with exit code 130, writing nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hillchart.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "run", help="simulate a plant file's scenario (load rejection, closure law, frequency/load/opening steps)",
        description="Simulate the scenario of a plant TOML file and write timeseries.csv, summary.json, "
                    "envelope.csv, transient.png and envelope.png into --out.")
    parser.add_argument("plant", type=Path, help="plant TOML file")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant-file key; the value is parsed as TOML (repeatable), "
                             "e.g. --set penstock.model=\"rigid\" --set scenario.t_end_s=30")
    parser.add_argument("--no-plot", action="store_true", help="do not write transient.png and envelope.png")
    parser.set_defaults(func=run_command)


def write_run_outputs(result, out: Path, *, plot: bool = True) -> list[Path]:
    """Every file of a run, in one place: timeseries.csv, envelope.csv, the figures, summary.json last."""
    from simulate.envelope import plot_envelope, write_envelope_csv

    written = [result.to_csv(out / "timeseries.csv"), write_envelope_csv(result, out / "envelope.csv")]
    if plot:
        result.plot(out / "transient.png")
        plot_envelope(result, out / "envelope.png")
        written += [out / "transient.png", out / "envelope.png"]
    written.append(result.to_json(out / "summary.json"))
    return written


def run_command(args: argparse.Namespace) -> int:
    from simulate.config import load_plant, parse_override
    from simulate.engine import run_simulation

    overrides = dict(parse_override(text) for text in args.overrides)
    plant = load_plant(args.plant, overrides)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} exists and is not a directory")
    reached = [0.0]

    def progress(step, n_steps):
        reached[0] = step / n_steps

    try:
        result = run_simulation(plant, raise_on_failure=False, progress=progress)
    except KeyboardInterrupt:
        print(f"hillsim run: interrupted after {100 * reached[0]:.0f} % of the run; nothing written", file=sys.stderr)
        return 130
    out.mkdir(parents=True, exist_ok=True)
    write_run_outputs(result, out, plot=not args.no_plot)
    summary = result.summary()
    for line in summary.get("warnings", []):
        print(f"hillsim run: warning: {line}", file=sys.stderr)
    print(f"{plant.scenario.kind}: {summary['steps']} steps of {summary['dt_s']:.6g} s, "
          f"max speed rise {100 * summary['max_speed_rise']:.2f} %, max head rise "
          f"{100 * summary['max_head_rise']:.2f} %, min head drop {100 * summary['min_head_drop']:.2f} %, "
          f"mean iterations {summary['mean_iterations']:.2f}; wrote {out}")
    if summary.get("frequency_recovery_time_s") is not None:  # the sub-transient generator after a load change
        print(f"frequency back within +-{summary['frequency_recovery_band_hz']} Hz of rated "
              f"{summary['frequency_recovery_time_s']:.2f} s after the load change at "
              f"{summary['frequency_event_time_s']:g} s (nadir {summary['min_frequency_hz']:.3f} Hz)")
    if not result.success:
        raise_message = f"{result.message} (series up to the failure written to {out})"
        from hillchart.errors import NumericalError
        raise NumericalError(raise_message)
    return 0
