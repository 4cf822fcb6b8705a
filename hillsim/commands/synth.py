"""``hillsim synth OUT_DIR [--seed N] [--turbine medium|bulb]``: write a synthetic turbine's data set."""

from __future__ import annotations

import argparse


def _write_medium(args):
    from hillchart.synthetic import write_synthetic_chart

    return write_synthetic_chart(args.out_dir, seed=args.seed)


def _write_bulb(args):
    from hillchart.bulb import write_bulb_table

    return write_bulb_table(args.out_dir, seed=args.seed, n_points=args.points, noise=args.noise,
                            closure=args.closure)


#: Turbine name -> writer (the digitized chart of the medium-head Francis; the bulb's model-test table).
TURBINES = {"medium": _write_medium, "bulb": _write_bulb}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="write a synthetic turbine's data (Francis chart folder, or bulb test table)",
        description="Write the digitized chart of hillsim's synthetic Francis turbine (--turbine medium) or the "
                    "model-test table (table.csv, table.toml) and exact truth grid (truth.csv) of the synthetic "
                    "double-regulated bulb turbine (--turbine bulb) into OUT_DIR.",
    )
    parser.add_argument("out_dir", metavar="OUT_DIR", help="folder to write (created if needed)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the digitization / measurement noise (default 0)")
    parser.add_argument("--turbine", choices=tuple(TURBINES), default="medium",
                        help="medium: Francis hill chart (default); bulb: double-regulated bulb test table")
    parser.add_argument("--noise", type=float, default=0.003,
                        help="bulb: relative measurement noise (std) of head, flow and power (default 0.003)")
    parser.add_argument("--points", type=int, default=150, help="bulb: scattered test points (default 150)")
    parser.add_argument("--closure", choices=("water-system", "best-efficiency"), default="water-system",
                        help="bulb: head on the plant's water system (default) or at each setting's best efficiency")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    written = TURBINES[args.turbine](args)
    for name, path in written.items():
        print(f"wrote {path}")
    return 0
