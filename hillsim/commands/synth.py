"""``hillsim synth OUT_DIR [--turbine NAME] [--seed N] [digitization options]``: write a synthetic chart as an
engineer would digitize it, with its exact truth grid."""

from __future__ import annotations

import argparse


def _francis_writer(name: str):
    def write(out_dir, *, seed: int, options):
        from hillchart.synthetic import write_synthetic_chart

        return write_synthetic_chart(out_dir, seed=seed, turbine=name, options=options)

    write.__doc__ = f"The synthetic Francis family member {name!r} (hillchart.synthetic.FAMILY)."
    return write


#: ``--turbine`` registry: name -> ``writer(out_dir, *, seed, options) -> {file name: path}``. Adding a synthetic
#: turbine is one line here.
TURBINE_WRITERS = {
    "slow": _francis_writer("slow"),
    "medium": _francis_writer("medium"),
    "fast": _francis_writer("fast"),
}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="write a synthetic turbine's digitized chart (chart.toml, flow/efficiency/runaway/truth CSV)",
        description="Write the digitized chart of one of hillsim's synthetic turbines into OUT_DIR, with its exact "
                    "truth grid (truth.csv). The medium Francis with default options is the shipped chart.",
    )
    parser.add_argument("out_dir", metavar="OUT_DIR", help="folder to write (created if needed)")
    parser.add_argument("--turbine", default="medium", metavar="NAME",
                        help=f"which synthetic turbine: {', '.join(TURBINE_WRITERS)} (default medium)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the digitization noise (default 0)")
    parser.add_argument("--points-per-line", type=int, default=7, help="points per opening line, 3-12 (default 7)")
    parser.add_argument("--spacing", default="even", help="'even' or 'uneven' spacing along the lines")
    parser.add_argument("--noise", type=float, default=0.15,
                        help="digitization noise, percent of the chart axes' full scale (medium chart: 100 r/min, 1 m^3/s; "
                             "default 0.15, allowed 0-5)")
    parser.add_argument("--opening-unit", default="mm", help="mm, deg or %% (default mm)")
    parser.add_argument("--q11-unit", default="m3/s", help="m3/s or l/s (default m3/s)")
    parser.add_argument("--efficiency-unit", default="fraction", help="fraction or percent (default fraction)")
    parser.add_argument("--opening-lines", type=int, default=None, help="use only this many opening lines (>= 3)")
    parser.add_argument("--no-runaway", action="store_true", help="do not write runaway.csv")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.errors import InputError
    from hillchart.synthetic import DigitizationOptions

    if args.turbine not in TURBINE_WRITERS:
        raise InputError(f"--turbine must be one of {', '.join(TURBINE_WRITERS)}, got {args.turbine!r}")
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0, got {args.seed}")
    try:
        options = DigitizationOptions(points_per_line=args.points_per_line, spacing=args.spacing,
                                      noise_pct=args.noise, opening_unit=args.opening_unit, q11_unit=args.q11_unit,
                                      efficiency_unit=args.efficiency_unit, runaway=not args.no_runaway,
                                      opening_lines=args.opening_lines)
    except InputError as exc:
        option = str(exc).split(" ", 1)[0].replace("_", "-").replace("noise-pct", "noise")
        raise InputError(f"--{option} {str(exc).split(' ', 1)[1]}") from None
    written = TURBINE_WRITERS[args.turbine](args.out_dir, seed=args.seed, options=options)
    for path in written.values():
        print(f"wrote {path}")
    return 0
