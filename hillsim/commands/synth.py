"""``hillsim synth OUT_DIR [--turbine NAME] [--seed N] [options]``: write a synthetic turbine's data set.

Francis family (``slow``, ``medium``, ``fast``): the digitized chart an engineer would draw from the manufacturer's
hill chart, with its exact truth grid. ``bulb``: the model-test table of the double-regulated bulb turbine
(``table.csv`` + ``table.toml``) and its exact truth grid.
"""

from __future__ import annotations

import argparse


def _francis_writer(name: str):
    def write(out_dir, args):
        from hillchart.errors import InputError
        from hillchart.synthetic.francis import DigitizationOptions, write_synthetic_chart

        try:
            options = DigitizationOptions(
                points_per_line=args.points_per_line, spacing=args.spacing,
                noise_pct=0.15 if args.noise is None else args.noise, opening_unit=args.opening_unit,
                q11_unit=args.q11_unit, efficiency_unit=args.efficiency_unit, runaway=not args.no_runaway,
                opening_lines=args.opening_lines)
        except InputError as exc:
            option = str(exc).split(" ", 1)[0].replace("_", "-").replace("noise-pct", "noise")
            raise InputError(f"--{option} {str(exc).split(' ', 1)[1]}") from None
        return write_synthetic_chart(out_dir, seed=args.seed, turbine=name, options=options)

    write.__doc__ = f"The synthetic Francis family member {name!r} (hillchart.synthetic.francis.FAMILY)."
    return write


def _write_bulb(out_dir, args):
    """The synthetic double-regulated bulb turbine's model-test table (hillchart.synthetic.bulb)."""
    from hillchart.synthetic.bulb import write_bulb_table
    from hillchart.errors import InputError

    noise_pct = 0.3 if args.noise is None else args.noise
    if not 0.0 <= noise_pct <= 5.0:
        raise InputError(f"--noise must be within 0-5 (percent), got {noise_pct}")
    if not 10 <= args.points <= 100000:
        raise InputError(f"--points must be within 10-100000, got {args.points}")
    return write_bulb_table(out_dir, seed=args.seed, n_points=args.points, noise=noise_pct / 100.0,
                            closure=args.closure)


#: ``--turbine`` registry: name -> ``writer(out_dir, args) -> {file name: path}``. Adding a synthetic turbine is one
#: line here.
TURBINE_WRITERS = {
    "slow": _francis_writer("slow"),
    "medium": _francis_writer("medium"),
    "fast": _francis_writer("fast"),
    "bulb": _write_bulb,
}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="write a synthetic turbine's data (Francis chart folder, or bulb model-test table)",
        description="Write the digitized chart of one of hillsim's synthetic Francis turbines (slow, medium, fast), "
                    "or the model-test table of the synthetic double-regulated bulb turbine (bulb), with the exact "
                    "truth grid (truth.csv), into OUT_DIR. The medium Francis with default options is the shipped "
                    "chart.",
    )
    parser.add_argument("out_dir", metavar="OUT_DIR", help="folder to write (created if needed)")
    parser.add_argument("--turbine", default="medium", metavar="NAME",
                        help=f"which synthetic turbine: {', '.join(TURBINE_WRITERS)} (default medium)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the digitization / measurement noise (default 0)")
    parser.add_argument("--noise", type=float, default=None,
                        help="noise in percent: Francis: of the chart axes' full scale (default 0.15); bulb: relative "
                             "std of head, flow and power (default 0.3); allowed 0-5")
    parser.add_argument("--points-per-line", type=int, default=7,
                        help="Francis: points per opening line, 3-12 (default 7)")
    parser.add_argument("--spacing", default="even", help="Francis: 'even' or 'uneven' spacing along the lines")
    parser.add_argument("--opening-unit", default="mm", help="Francis: mm, deg or %% (default mm)")
    parser.add_argument("--q11-unit", default="m3/s", help="Francis: m3/s or l/s (default m3/s)")
    parser.add_argument("--efficiency-unit", default="fraction", help="Francis: fraction or percent (default fraction)")
    parser.add_argument("--opening-lines", type=int, default=None,
                        help="Francis: use only this many opening lines (>= 3)")
    parser.add_argument("--no-runaway", action="store_true", help="Francis: do not write runaway.csv")
    parser.add_argument("--points", type=int, default=150, help="bulb: scattered test points (default 150)")
    parser.add_argument("--closure", choices=("water-system", "best-efficiency", "propeller-curves"),
                        default="water-system",
                        help="bulb: head on the plant's water system (default), at each setting's best efficiency, "
                             "or stepped at each setting over five unit speeds (a model test's propeller curves)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.errors import InputError

    if args.turbine not in TURBINE_WRITERS:
        raise InputError(f"--turbine must be one of {', '.join(TURBINE_WRITERS)}, got {args.turbine!r}")
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0, got {args.seed}")
    out = args.outputs.folder("OUT_DIR", args.out_dir)
    written = TURBINE_WRITERS[args.turbine](out, args)
    for name in written:
        print(f"wrote {args.out_dir}/{name}")
    return 0
