"""``hillsim run plant.toml --out DIR [--set section.key=value ...]``: simulate a plant's scenario.

Writes ``DIR/timeseries.csv``, ``DIR/summary.json`` and ``DIR/transient.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from hillchart.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "run", help="simulate a plant file's scenario (load rejection, closure law, frequency/load/opening steps)",
        description="Simulate the scenario of a plant TOML file and write timeseries.csv, summary.json and "
                    "transient.png into --out.")
    parser.add_argument("plant", type=Path, help="plant TOML file")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant-file key; the value is parsed as TOML (repeatable), "
                             "e.g. --set penstock.model=\"rigid\" --set scenario.t_end_s=30")
    parser.add_argument("--no-plot", action="store_true", help="do not write transient.png")
    parser.add_argument("--uncertainty", action="store_true",
                        help="also run the scenario once per ensemble member of the nets and add the 5-95 %% band "
                             "of max speed rise and max/min head to summary.json (issue 9)")
    parser.set_defaults(func=run_command)


def run_command(args: argparse.Namespace) -> int:
    from simulate.config import load_plant, parse_override
    from simulate.engine import run_simulation

    overrides = dict(parse_override(text) for text in args.overrides)
    plant = load_plant(args.plant, overrides)
    result = run_simulation(plant, raise_on_failure=False)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    result.to_csv(out / "timeseries.csv")
    result.to_json(out / "summary.json")
    if not args.no_plot:
        result.plot(out / "transient.png")
    summary = result.summary()
    print(f"{plant.scenario.kind}: {summary['steps']} steps of {summary['dt_s']:.6g} s, "
          f"max speed rise {100 * summary['max_speed_rise']:.2f} %, max head rise "
          f"{100 * summary['max_head_rise']:.2f} %, min head drop {100 * summary['min_head_drop']:.2f} %, "
          f"mean iterations {summary['mean_iterations']:.2f}; wrote {out}")
    if getattr(args, "uncertainty", False) and result.success:
        _add_uncertainty(plant, out / "summary.json")
    if not result.success:
        raise_message = f"{result.message} (series up to the failure written to {out})"
        from hillchart.errors import NumericalError
        raise NumericalError(raise_message)
    return 0


def _add_uncertainty(plant, summary_path: Path) -> None:
    """Minimal hook: the band from :func:`simulate.uncertainty.run_members` goes into summary.json."""
    import json

    from simulate.uncertainty import run_members

    band = run_members(plant)
    summary = json.loads(summary_path.read_text(encoding="utf-8"))
    summary["uncertainty"] = band
    summary_path.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    print(f"ensemble of {band['members']} ({len(band['failed'])} failed): max speed rise "
          f"{100 * band['max_speed_rise']['low']:.2f}-{100 * band['max_speed_rise']['high']:.2f} %, max head rise "
          f"{100 * band['max_head_rise']['low']:.2f}-{100 * band['max_head_rise']['high']:.2f} %, min head drop "
          f"{100 * band['min_head_drop']['low']:.2f}-{100 * band['min_head_drop']['high']:.2f} % (5-95 %)")
