"""``hillsim synth OUT_DIR [--seed N]``: write the synthetic Francis chart an engineer would digitize."""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="write the synthetic Francis chart (chart.toml, flow/efficiency/runaway/truth CSV)",
        description="Write the digitized chart of hillsim's synthetic Francis turbine into OUT_DIR.",
    )
    parser.add_argument("out_dir", metavar="OUT_DIR", help="folder to write (created if needed)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the digitization noise (default 0)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.synthetic import write_synthetic_chart

    written = write_synthetic_chart(args.outputs.folder("OUT_DIR", args.out_dir), seed=args.seed)
    for name in written:
        print(f"wrote {args.out_dir}/{name}")
    return 0
